"""Surface textures on the device: one ``sampler2DArray`` of atlas pages and a table of
texture records (``shaders/bsdf/texture.glsl`` reads both).

GLSL cannot index an array of samplers with a value that varies per ray, so every
bitmap goes into one array texture: its layers are atlas pages, square and as large as
the largest bitmap (up to :data:`PAGE_SIZE` when that packs all on one page), and bitmaps are packed into them on
shelves (tallest first), each at its own offset, so dozens of textures of different
sizes share a few pages instead of taking a page as large as the largest each.
Filtering (nearest or bilinear, Mitsuba's ``uv * size - 0.5`` texel centres) and
wrapping (repeat, mirror, clamp) happen in the shader with ``texelFetch``, per texture
and inside its own rectangle, so neighbours never bleed into each other without any
padding, and each texture keeps its own filter and wrap mode.

Layers are stored as half floats (RGBA16F): a linear colour keeps a relative error
below 2^-11, far below what 8-bit sources resolve. Bitmaps wider or taller than
:data:`MAX_TEXTURE_SIZE` are box-filtered down by powers of two first.

Texture record (5 RGBA32F texels per texture, in a buffer texture):

    0: kind (0 bitmap, 1 checkerboard), layer (atlas page), width, height
    1: first row of the 2x3 uv transform, filter (0 nearest, 1 bilinear)
    2: second row of the uv transform, wrap (0 repeat, 1 mirror, 2 clamp)
    3: checkerboard colour 0 (rgb); bitmaps: the texel offset (x, y) in the page
    4: checkerboard colour 1 (rgb)
"""
from __future__ import annotations

import hashlib

import numpy as np

from ..errors import SceneError
from ..scene import model as m

RECORD_TEXELS = 5
KINDS = {"bitmap": 0, "checkerboard": 1}
FILTERS = {"nearest": 0, "bilinear": 1}
WRAPS = {"repeat": 0, "mirror": 1, "clamp": 2}
MAX_TEXTURE_SIZE = 4096
MAX_LAYER_BYTES = 1 << 30          # all layers together, as RGBA16F
PAGE_SIZE = 2048                   # atlas pages are at least this wide and tall


def pack_shelves(sizes: list[tuple[int, int]], page: int) -> list[tuple[int, int, int]]:
    """Places rectangles (height, width) on shelves in square pages of side ``page``:
    returns (page, x, y) per rectangle. Tallest first; a shelf is as tall as its first
    rectangle; a rectangle that does not fit the shelf's remaining width opens a new
    shelf, one that does not fit below the last shelf opens a new page."""
    order = sorted(range(len(sizes)), key=lambda i: (-sizes[i][0], -sizes[i][1]))
    places: list[tuple[int, int, int]] = [(0, 0, 0)] * len(sizes)
    layer, shelf_y, shelf_h, x = 0, 0, 0, 0
    for i in order:
        h, w = sizes[i]
        if h > page or w > page:
            raise ValueError(f"a {w}x{h} image does not fit pages of {page}")
        if x + w > page:                      # next shelf
            shelf_y, shelf_h, x = shelf_y + shelf_h, 0, 0
        if shelf_y + h > page:                # next page
            layer, shelf_y, shelf_h, x = layer + 1, 0, 0, 0
        places[i] = (layer, x, shelf_y)
        shelf_h = max(shelf_h, h)
        x += w
    return places


def _box_halve(image: np.ndarray) -> np.ndarray:
    h, w = image.shape[:2]
    h2, w2 = max(h // 2, 1), max(w // 2, 1)
    img = image[:h2 * 2 if h > 1 else 1, :w2 * 2 if w > 1 else 1]
    fy, fx = (2 if h > 1 else 1), (2 if w > 1 else 1)
    return img.reshape(h2, fy, w2, fx, -1).mean(axis=(1, 3))


def _prepare_image(texture: m.Texture, what: str) -> np.ndarray:
    image = texture.image
    if image is None:
        raise SceneError(f"{what}: a bitmap texture without an image")
    image = np.asarray(image, np.float32)
    if image.ndim == 2:
        image = image[..., None]
    if image.ndim != 3 or image.shape[0] < 1 or image.shape[1] < 1 or image.shape[2] < 1:
        raise SceneError(f"{what}: expected an H x W x 3 image, got shape {image.shape}")
    if image.shape[2] == 1:
        image = np.repeat(image, 3, axis=2)
    image = image[..., :3]
    if not np.all(np.isfinite(image)):
        raise SceneError(f"{what}: the image holds NaN or infinite values")
    while max(image.shape[:2]) > MAX_TEXTURE_SIZE:
        image = _box_halve(image)
    return image


class TextureTable:
    """The textures of a scene's materials, numbered in order of first use.

    ``index(texture)`` returns the texture's index + 1 (0 means no texture), the
    value a material record stores in ``info.z`` / ``info.w``.
    """

    def __init__(self):
        self.textures: list[m.Texture] = []
        self._ids: dict[int, int] = {}

    def __len__(self) -> int:
        return len(self.textures)

    def index(self, texture: m.Texture, what: str = "texture") -> int:
        key = id(texture)
        if key not in self._ids:
            if texture.kind not in KINDS:
                raise SceneError(f"{what}: unknown texture kind {texture.kind!r} "
                                 f"(expected bitmap or checkerboard)")
            for name, table in (("filter", FILTERS), ("wrap", WRAPS)):
                if getattr(texture, name) not in table:
                    raise SceneError(f"{what}: {name} must be one of {', '.join(table)}, "
                                     f"got {getattr(texture, name)!r}")
            M = np.asarray(texture.uv_transform, np.float64)
            if M.shape != (3, 3) or not np.all(np.isfinite(M)):
                raise SceneError(f"{what}: uv_transform must be a finite 3x3 matrix")
            self.textures.append(texture)
            self._ids[key] = len(self.textures)
        return self._ids[key]

    def build(self) -> tuple[np.ndarray, np.ndarray]:
        """(layers (L, H, W, 4) float16, records (N * RECORD_TEXELS, 4) float32).

        With no bitmap, one 1x1 black layer keeps the array texture valid."""
        images: list[np.ndarray] = []
        records = np.zeros((max(len(self.textures), 1) * RECORD_TEXELS, 4), np.float32)
        for k, tex in enumerate(self.textures):
            what = f"texture {tex.name or k}"
            rec = records[k * RECORD_TEXELS:(k + 1) * RECORD_TEXELS]
            M = np.asarray(tex.uv_transform, np.float64)
            rec[0, 0] = KINDS[tex.kind]
            rec[1] = (M[0, 0], M[0, 1], M[0, 2], FILTERS[tex.filter])
            rec[2] = (M[1, 0], M[1, 1], M[1, 2], WRAPS[tex.wrap])
            if tex.kind == "bitmap":
                image = _prepare_image(tex, what)
                rec[0, 1:] = (len(images), image.shape[1], image.shape[0])
                images.append(image)
            else:
                for row, color in ((3, tex.color0), (4, tex.color1)):
                    rgb = np.broadcast_to(np.asarray(color, np.float64).reshape(-1), (3,))
                    if not np.all(np.isfinite(rgb)):
                        raise SceneError(f"{what}: checkerboard colours must be finite")
                    rec[row, :3] = rgb
        if not images:
            return np.zeros((1, 1, 1, 4), np.float16), records
        while True:
            # the smallest page (from the largest bitmap's side, doubling up to PAGE_SIZE)
            # that holds everything on one page, else pages of PAGE_SIZE
            page = max(max(img.shape[:2]) for img in images)
            while True:
                places = pack_shelves([img.shape[:2] for img in images], page)
                pages = 1 + max(p[0] for p in places)
                if pages == 1 or page >= PAGE_SIZE:
                    break
                page = min(PAGE_SIZE, 2 * page)
            if pages * page * page * 8 <= MAX_LAYER_BYTES:
                break
            # too much memory for one array: halve the largest image and pack again
            big = max(range(len(images)), key=lambda i: images[i].size)
            images[big] = _box_halve(images[big])
        layers = np.zeros((pages, page, page, 4), np.float16)
        for k, tex in enumerate(self.textures):
            if tex.kind != "bitmap":
                continue
            base = k * RECORD_TEXELS
            i = int(records[base, 1])          # the image's index, before packing
            img = images[i]
            layer, x, y = places[i]
            records[base, 1:4] = (layer, img.shape[1], img.shape[0])
            records[base + 3, :2] = (x, y)
        for img, (layer, x, y) in zip(images, places):
            layers[layer, y:y + img.shape[0], x:x + img.shape[1], :3] = img
            layers[layer, y:y + img.shape[0], x:x + img.shape[1], 3] = 1.0
        return layers, records

    def fingerprint(self) -> bytes:
        """A digest of every texture's data (images, colours, transforms, modes)."""
        h = hashlib.sha256()
        for tex in self.textures:
            h.update(repr((tex.kind, tex.filter, tex.wrap, tex.color0, tex.color1)).encode())
            h.update(np.ascontiguousarray(tex.uv_transform, np.float64).tobytes())
            if tex.image is not None:
                h.update(np.ascontiguousarray(tex.image, np.float32).tobytes())
        return h.digest()


def upload(ctx, table: TextureTable, where: str = "the scene"):
    """The array texture and record buffer texture of ``table`` on the device:
    (moderngl TextureArray, BufferTexture). ``where`` names the scene in errors."""
    from ..gl.buffers import BufferTexture

    gl = getattr(ctx, "gl", ctx)
    layers, records = table.build()
    n, h, w = layers.shape[:3]
    limit = gl.info.get("GL_MAX_ARRAY_TEXTURE_LAYERS", 256)
    if n > limit:
        raise SceneError(f"{where}: its bitmap textures take {n} atlas pages of {w} x {h} texels; "
                         f"this device's texture arrays hold at most {limit} (fewer or smaller "
                         f"images)")
    array = gl.texture_array((w, h, n), 4, np.ascontiguousarray(layers).tobytes(), dtype="f2")
    array.filter = (gl.NEAREST, gl.NEAREST)   # the shader filters (texelFetch)
    return array, BufferTexture(ctx, records, "rgba32f", "texture records")
