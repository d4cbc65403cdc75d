"""Surface textures on the device: texture_eval against a numpy model of Mitsuba's
bitmap (nearest / bilinear, repeat / mirror / clamp) and checkerboard, and a textured
quad through the whole renderer in Mitsuba's orientation."""
import numpy as np
import pytest

import glrender
from glrender.gpu import bindings, textures
from glrender.scene import model as m
from glrender.testing.harness import run_glsl

# Layers are RGBA16F: a stored value carries a relative rounding error <= 2^-11; a
# bilinear mix of four such values stays within that bound of the exact mix (weights
# are float32). Values are in [0, 1], so 2^-11 absolute bounds every error.
F16_TOL = 2.0 ** -11 + 1e-6


def _wrap(i, n, mode):
    if mode == "clamp":
        return np.clip(i, 0, n - 1)
    if mode == "mirror":
        j = np.mod(i, 2 * n)
        return np.where(j < n, j, 2 * n - 1 - j)
    return np.mod(i, n)


def reference(tex: m.Texture, uv: np.ndarray) -> np.ndarray:
    """Mitsuba's texture evaluation in numpy (float64)."""
    M = tex.uv_transform
    st = uv @ M[:2, :2].T + M[:2, 2]
    if tex.kind == "checkerboard":
        upper = (st - np.floor(st)) > 0.5
        return np.where((upper[:, 0] == upper[:, 1])[:, None], tex.color0, tex.color1)
    img = tex.image.astype(np.float64)
    h, w = img.shape[:2]
    x = st * [w, h]
    if tex.filter == "nearest":
        i = np.floor(x).astype(np.int64)
        return img[_wrap(i[:, 1], h, tex.wrap), _wrap(i[:, 0], w, tex.wrap)]
    x = x - 0.5
    i0 = np.floor(x).astype(np.int64)
    f = x - i0
    out = 0
    for dy in (0, 1):
        for dx in (0, 1):
            wgt = (f[:, 0] if dx else 1 - f[:, 0]) * (f[:, 1] if dy else 1 - f[:, 1])
            out = out + wgt[:, None] * img[_wrap(i0[:, 1] + dy, h, tex.wrap), _wrap(i0[:, 0] + dx, w, tex.wrap)]
    return out


def evaluate(gl_ctx, table: textures.TextureTable, index: np.ndarray, uv: np.ndarray) -> np.ndarray:
    array, records = textures.upload(gl_ctx, table)
    try:
        array.use(bindings.TEX_TEXTURES)
        records.bind(bindings.TEX_TEXTURE_RECORDS)
        out = run_glsl("vec3 c = texture_eval(k, uv);",
                       inputs={"k": index.astype(np.uint32), "uv": uv.astype(np.float32)},
                       outputs={"c": "vec3"}, includes=["bsdf/texture.glsl"], ctx=gl_ctx)
        return out["c"]
    finally:
        array.release()
        records.release()


@pytest.mark.parametrize("filt", ["nearest", "bilinear"])
def test01_bitmaps_match_mitsubas_lookup(gl_ctx, filt):
    rng = np.random.default_rng(7)
    # sizes differ: each texture sits at its own offset in a shared atlas page
    texs = [m.Texture("bitmap", image=rng.random((h, w, 3)).astype(np.float32), filter=filt, wrap=wrap)
            for (h, w), wrap in (((3, 5), "repeat"), ((7, 4), "mirror"), ((2, 2), "clamp"))]
    texs[1].uv_transform = np.array([[2.0, 0.5, 0.1], [-0.3, 1.5, 0.2], [0, 0, 1]])
    table = textures.TextureTable()
    for t in texs:
        table.index(t)
    n = 30000
    index = rng.integers(0, 3, n)
    uv = rng.uniform(-3, 3, (n, 2))
    got = evaluate(gl_ctx, table, index, uv)
    want = np.empty((n, 3))
    for k, t in enumerate(texs):
        sel = index == k
        # round the uv as the device sees it (float32), then evaluate exactly
        want[sel] = reference(t, uv[sel].astype(np.float32).astype(np.float64))
    err = np.abs(got - want)
    if filt == "nearest":
        # a float32 uv within rounding of a texel edge may pick either neighbour
        assert np.mean(err.max(axis=1) > F16_TOL) < 1e-3
    else:
        assert err.max() <= F16_TOL + 4e-6     # plus the float32 weights' rounding


def test02_checkerboard_edges(gl_ctx):
    tex = m.Texture("checkerboard", color0=(1, 0, 0), color1=(0, 0, 1),
                    uv_transform=np.diag([4.0, 4.0, 1.0]))
    table = textures.TextureTable()
    table.index(tex)
    eps = 1e-3
    # both sides of the edges at u = 0.125 (one check = 1/8 of uv with 4x scaling) and of 0
    u = np.array([0.125 - eps, 0.125 + eps, -eps, eps, 0.3, 0.3, 0.3])
    v = np.array([0.1, 0.1, 0.1, 0.1, 0.125 - eps, 0.125 + eps, -0.3])
    got = evaluate(gl_ctx, table, np.zeros(len(u), np.int64), np.stack([u, v], axis=1))
    np.testing.assert_array_equal(got, reference(tex, np.stack([u, v], axis=1)))
    assert got[0].tolist() != got[1].tolist() and got[2].tolist() != got[3].tolist()


def test03_textured_quad_in_mitsubas_orientation():
    # A 2x2 image (rows top to bottom: red green / blue white) on Mitsuba's rectangle seen
    # from +z, nearest filter. Mitsuba 3.9 (scalar_rgb, same camera) renders the image
    # upside down: blue at the top left, white top right, red bottom left, green bottom
    # right (its rectangle's v grows with y while v = 0 is the image's first row).
    image = np.array([[[1, 0, 0], [0, 1, 0]], [[0, 0, 1], [1, 1, 1]]], np.float32)
    scene = m.Scene(film=m.Film(8, 8, filter="box"), integrator=m.Integrator("path", max_depth=2))
    scene.camera = m.Camera(world_from_camera=m.look_at((0, 0, 3), (0, 0, 0), (0, 1, 0)), fov=40)
    scene.materials.append(m.Material("diffuse", reflectance=m.Texture("bitmap", image=image,
                                                                        filter="nearest")))
    scene.shapes.append(m.Shape("rectangle"))
    scene.lights.append(m.Light("constant"))
    spp = 256
    film = glrender.render(scene, spp=spp, seed=3, sampler="independent")
    # pixels 3 and 4 see the quad's inner quarter: a diffuse plane under a uniform sky of
    # radiance 1 reflects its albedo. sigma from the per-sample variance (independent
    # samples); z = 4.5 over 12 values is far beyond Sidak's 3.3 at alpha = 0.01; a swapped
    # orientation moves a channel by 1, about 20 sigma
    got = film.mean[3:5, 3:5]
    sigma = np.sqrt(film.variance[3:5, 3:5] / spp)
    want = np.array([[[0, 0, 1], [1, 1, 1]], [[1, 0, 0], [0, 1, 0]]])
    assert np.all(np.abs(got - want) <= 4.5 * sigma + 1e-5), (got, sigma)


_UV_SCENE = """<scene version="3.0.0">
    <integrator type="path"><integer name="max_depth" value="2"/></integrator>
    <sensor type="perspective"><float name="fov" value="40"/>
        <transform name="to_world"><lookat origin="1, 2, 3" target="0, 0, 0" up="0, 1, 0"/></transform>
        <film type="hdrfilm"><integer name="width" value="48"/><integer name="height" value="48"/>
            <rfilter type="box"/></film>
        <sampler type="independent"><integer name="sample_count" value="16"/></sampler></sensor>
    <emitter type="constant"/>
    <shape type="SHAPE">FLIP
        <bsdf type="twosided"><bsdf type="diffuse"><texture type="checkerboard" name="reflectance">
            <rgb name="color0" value="1, 0, 0"/><rgb name="color1" value="0, 0, 1"/>
            <transform name="to_uv"><scale x="3" y="4"/></transform></texture></bsdf></bsdf></shape>
</scene>
"""


@pytest.mark.parametrize("shape, flip", [
    ("rectangle", False),
    ("disk", False),
    ("obj", False),
    ("ply", False),
    ("cube", False),
    ("sphere", False),
    ("rectangle", True),
])
def test04_uv_conventions_match_mitsuba(write, shape, flip):
    mi = pytest.importorskip("mitsuba")
    mi.set_variant("scalar_rgb")
    # a quad with uv = (x + 1, y + 1) / 2 in each mesh format (OBJ's v counts up: flipped on load)
    write("quad.obj", "v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n"
                      "f 1/1 2/2 3/3\nf 1/1 3/3 4/4\n")
    write("quad.ply", "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
                      "property float z\nproperty float u\nproperty float v\nelement face 2\n"
                      "property list uchar int vertex_indices\nend_header\n-1 -1 0 0 0\n1 -1 0 1 0\n"
                      "1 1 0 1 1\n-1 1 0 0 1\n3 0 1 2\n3 0 2 3\n")
    extra = '<boolean name="flip_normals" value="true"/>' if flip else ""
    if shape in ("obj", "ply"):
        extra = f'<string name="filename" value="quad.{shape}"/>'
    path = write("uv.xml", _UV_SCENE.replace("SHAPE", shape).replace("FLIP", extra))
    theirs = np.asarray(mi.render(mi.load_file(str(path))))[..., :3]
    ours = glrender.render(glrender.load(path), seed=1).mean
    # the checks are red or blue, the sky white: compare which of red and blue each pixel
    # of the surface shows (pixels on check edges mix both and may differ)
    covered = (np.abs(theirs[..., 0] - theirs[..., 2]) > 0.3) | (np.abs(ours[..., 0] - ours[..., 2]) > 0.3)
    mismatch = (theirs[..., 0] > theirs[..., 2]) != (ours[..., 0] > ours[..., 2])
    assert covered.sum() > 300
    # edge pixels (a check spans ~6 pixels here) stay well below 15%; a uv half a turn or
    # transposed swaps about half of the checks
    assert mismatch[covered].mean() < 0.15


def _png_header_claiming(width: int, height: int) -> bytes:
    """A PNG signature and IHDR chunk claiming width x height RGB pixels, and no data."""
    import struct
    import zlib

    ihdr = struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)
    chunk = b"IHDR" + ihdr
    return (b"\x89PNG\r\n\x1a\n" + struct.pack(">I", len(ihdr)) + chunk +
            struct.pack(">I", zlib.crc32(chunk)) + b"\0\0\0\0IEND\xaeB`\x82")


@pytest.mark.parametrize("fmt", ["toml", "obj", "xml"])
@pytest.mark.parametrize("size", [12000,         # above glrender's 2^26 pixels (8192 x 8192)
                                  100000])       # above Pillow's own limit: ours, no warning
def test05_huge_texture_headers_are_refused_before_decoding(write, fmt, size):
    import warnings

    from glrender.errors import SceneError

    write("huge.png", _png_header_claiming(size, size))
    if fmt == "toml":
        path = write("s.toml", '[textures.t]\nfile = "huge.png"\n[materials.a]\nreflectance = "t"\n'
                               '[[shapes]]\ntype = "sphere"\nmaterial = "a"\n')
    elif fmt == "obj":
        write("m.mtl", "newmtl a\nmap_Kd huge.png\n")
        path = write("s.obj", "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl a\nf 1 2 3\n")
    else:
        path = write("s.xml", '<scene version="3.0.0"><shape type="sphere"><bsdf type="diffuse">'
                              '<texture type="bitmap" name="reflectance"><string name="filename" '
                              'value="huge.png"/></texture></bsdf></shape></scene>')
    where = {"toml": r"s\.toml: textures\.t\.file: image", "obj": r"m\.mtl:2: texture",
             "xml": r"s\.xml:1: texture"}[fmt]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        with pytest.raises(SceneError, match=rf"{where} 'huge\.png': {size} x {size} pixels is "
                                             rf"more than the 67,108,864 \(8192 x 8192\) a "
                                             rf"texture or environment map may have$"):
            glrender.load(path)
    assert [str(w.message) for w in caught] == []          # PIL's DecompressionBombWarning


# One rule for every format: at most 2^26 pixels, whatever the shape, read from the header.
_HEADERS = {
    "png": _png_header_claiming,
    "pfm": lambda w, h: f"PF\n{w} {h}\n-1.0\n".encode(),
    "hdr": lambda w, h: f"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y {h} +X {w}\n".encode(),
    "npy": lambda w, h: _npy_header((h, w, 3)),
}


def _npy_header(shape) -> bytes:
    import io as _io

    out = _io.BytesIO()
    np.lib.format.write_array_header_1_0(out, {"descr": "<f4", "fortran_order": False,
                                                "shape": shape})
    return out.getvalue()


@pytest.mark.parametrize("ext", list(_HEADERS))
@pytest.mark.parametrize("width, height, refused", [
    (8193, 8192, True),          # one column more than 8192 x 8192
    (16384, 4096, False),        # as many pixels as 8192 x 8192, another shape: allowed
])
def test06_one_pixel_limit_for_every_format(write, ext, width, height, refused):
    from glrender.errors import SceneError

    write(f"t.{ext}", _HEADERS[ext](width, height))           # a header, no pixels
    path = write("s.toml", f'[textures.t]\nfile = "t.{ext}"\n[materials.a]\nreflectance = "t"\n'
                           '[[shapes]]\ntype = "sphere"\nmaterial = "a"\n')
    with pytest.raises(SceneError) as info:
        glrender.load(path)
    line = str(info.value)
    assert line.startswith(f"{path}: textures.t.file: image 't.{ext}': ") and line.count(f"t.{ext}") == 1
    if refused:
        assert line.endswith(f"{width} x {height} pixels is more than the 67,108,864 (8192 x 8192) "
                             f"a texture or environment map may have"), line
    else:                        # past the size check: the missing pixels are what fails
        assert "cannot decode it" in line and "more than" not in line, line


def test09_atlas_packs_many_textures_without_overlap(gl_ctx):
    """Forty bitmaps of very different sizes share a few atlas pages (memory far below one
    page per bitmap), no two overlap, and every lookup reads its own bitmap exactly."""
    rng = np.random.default_rng(11)
    sizes = [(int(rng.integers(1, 300)), int(rng.integers(1, 300))) for _ in range(39)] + [(700, 1000)]
    places = textures.pack_shelves(sizes, 2048)
    cover = np.zeros((1 + max(p[0] for p in places), 2048, 2048), np.int32)
    for (h, w), (layer, x, y) in zip(sizes, places):
        assert x + w <= 2048 and y + h <= 2048
        cover[layer, y:y + h, x:x + w] += 1
    assert cover.max() == 1                         # no texel holds two bitmaps

    texs = [m.Texture("bitmap", image=rng.random((h, w, 3)).astype(np.float32),
                      filter=("nearest", "bilinear")[k % 2], wrap=("repeat", "mirror", "clamp")[k % 3])
            for k, (h, w) in enumerate(sizes)]
    table = textures.TextureTable()
    for t in texs:
        table.index(t)
    layers, _ = table.build()
    assert layers.nbytes <= len(texs) * 1000 * 1000 * 8 / 4      # vs a 1000^2 layer each
    n = 40000
    index = rng.integers(0, len(texs), n)
    uv = rng.uniform(-2, 2, (n, 2))
    got = evaluate(gl_ctx, table, index, uv)
    want = np.empty((n, 3))
    for k, t in enumerate(texs):
        sel = index == k
        want[sel] = reference(t, uv[sel].astype(np.float32).astype(np.float64))
    bilinear = np.array([texs[k].filter == "bilinear" for k in index])
    err = np.abs(got - want).max(axis=1)
    assert err[bilinear].max() <= F16_TOL + 4e-6
    assert np.mean(err[~bilinear] > F16_TOL) < 1e-3   # float32 uv at a texel edge


def test10_more_atlas_pages_than_the_device_holds_names_the_scene():
    """A device whose texture arrays hold fewer layers than the atlas needs: one line naming
    the scene, the pages and the device's limit (before anything is uploaded)."""
    from types import SimpleNamespace

    from glrender.errors import SceneError

    table = textures.TextureTable()
    for k in range(2):                 # two 2048^2 images: two full pages
        table.index(m.Texture("bitmap", image=np.full((2048, 2048, 3), 0.1 * k, np.float32)))
    gl = SimpleNamespace(info={"GL_MAX_ARRAY_TEXTURE_LAYERS": 1})
    with pytest.raises(SceneError, match=r"^scene\.toml: its bitmap textures take 2 atlas pages "
                                         r"of 2048 x 2048 texels; this device's texture arrays "
                                         r"hold at most 1"):
        textures.upload(SimpleNamespace(gl=gl), table, "scene.toml")
