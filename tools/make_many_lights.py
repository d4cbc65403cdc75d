#!/usr/bin/env python3
"""Write scenes/many-lights/: a 40 x 40 street grid at night lit by 5,000 windows and 500 lamps,
the scene of benchmarks/many_lights.py (light selection for next-event estimation).

Fifteen box buildings stand in the blocks between a main street (along z), two side streets and
two cross streets. 5,000 lit windows (emissive quads 0.2 x 0.3, one-sided, on the facades that
face a street; the other window slots stay dark), 250 street lamps (spot lights pointing down,
on the sidewalks) and 250 lanterns (point lights beside the facades, at the ground floor). Each
light's power is its kind's largest times 10^(-3u), u uniform in [0, 1): log-uniform over three
decades. A very dim sky (a constant environment) is the only other light. The camera stands on
the main street a little above the pavement and looks along it: most lights are hidden behind
buildings or far away, which is what a light selection must find out.

Everything comes from one seeded generator, so the files are made again byte for byte:
scene.toml (glrender's format) and scene.xml (Mitsuba 3's, the same scene: glrender loads
either to the same image), and window.ply, the unit quad that every window places.

    .venv/bin/python tools/make_many_lights.py
"""
from __future__ import annotations

import struct
from dataclasses import dataclass
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "scenes" / "many-lights"
SEED = 2018
HALF = 20.0                      # the ground spans [-20, 20]^2 in x and z
N_WINDOWS, N_SPOTS, N_POINTS = 5000, 250, 250
DECADES = 3.0
WINDOW_HALF = (0.1, 0.15)        # half width, half height: 0.2 x 0.3
# the largest of each kind (scene units: W/(m^2 sr) for windows, W/sr for lamps), chosen for
# an image that is neither dark nor blown out at the camera's exposure of 1
WINDOW_RADIANCE, SPOT_INTENSITY, POINT_INTENSITY = 15.0, 11.0, 1.7
SKY = (0.002, 0.003, 0.006)
MAX_DEPTH = 6
WIDTH, HEIGHT, FOV = 320, 180, 60
CAMERA = dict(origin=(1.2, 2.0, -19.0), target=(-0.3, 3.2, 2.0), up=(0, 1, 0))
# window tints, picked at random per window: incandescent, cool white, neutral; every tint has
# luminance 1, so that a light's power is its kind's largest times its factor alone
LUMINANCE = np.array([0.2126, 0.7152, 0.0722])
WINDOW_TINTS = tuple(np.array(t) / (LUMINANCE @ t) for t in ((1.0, 0.72, 0.42), (0.62, 0.78, 1.0),
                                                              (1.0, 0.93, 0.8)))
SPOT_TINT, POINT_TINT = (np.array(t) / (LUMINANCE @ t) for t in ((1.0, 0.6, 0.28), (1.0, 0.82, 0.6)))
MATERIALS = {"asphalt": 0.12, "brick": (0.42, 0.26, 0.2), "plaster": (0.58, 0.55, 0.5),
             "concrete": (0.38, 0.38, 0.4), "window": 0.05}
# the open ground between blocks: (axis, low, high) bands along x ("x": low < x < high) or z
STREETS = (("x", -3.0, 3.0), ("x", 11.0, 14.0), ("x", -14.0, -11.0), ("z", -8.5, -5.5), ("z", 5.5, 8.5))
BLOCKS_X = ((-20.0, -14.0), (-11.0, -3.0), (3.0, 11.0), (14.0, 20.0))
BLOCKS_Z = ((-20.0, -8.5), (-5.5, 5.5), (8.5, 20.0))
SIDEWALK = 0.6
# blocks (column, row) split into two buildings along z with an alley between them
SPLIT = {(1, 0), (2, 2), (1, 2)}
# window slots on a facade: columns every 0.4, floors every 0.7 from 1.2 up to 0.6 below the roof
COLUMN, FLOOR, FIRST_FLOOR = 0.4, 0.7, 1.2


@dataclass
class Box:
    lo: np.ndarray               # (x, z) of the footprint's corners
    hi: np.ndarray
    height: float
    material: str


@dataclass
class Window:
    center: np.ndarray
    facing: float                # rotation about +y (degrees) turning +z into the facade's normal
    radiance: tuple


def buildings(rng: np.random.Generator) -> list[Box]:
    """One box per block (two in the SPLIT blocks), of random height and material."""
    out = []
    for i, (x0, x1) in enumerate(BLOCKS_X):
        for j, (z0, z1) in enumerate(BLOCKS_Z):
            # a sidewalk along every street side; the map's edge is built up to
            lo = np.array([x0 + (SIDEWALK if x0 > -HALF else 0), z0 + (SIDEWALK if z0 > -HALF else 0)])
            hi = np.array([x1 - (SIDEWALK if x1 < HALF else 0), z1 - (SIDEWALK if z1 < HALF else 0)])
            parts = [(lo, hi)]
            if (i, j) in SPLIT:
                mid = 0.5 * (lo[1] + hi[1])
                parts = [(lo, np.array([hi[0], mid - 0.5])), (np.array([lo[0], mid + 0.5]), hi)]
            for a, b in parts:
                out.append(Box(a, b, float(rng.uniform(4.5, 13.0)),
                               ("brick", "plaster", "concrete")[int(rng.integers(3))]))
    return out


def in_street(x: float, z: float) -> bool:
    return abs(x) < HALF and abs(z) < HALF and any(
        lo < (x if axis == "x" else z) < hi for axis, lo, hi in STREETS)


def window_slots(boxes: list[Box]) -> list[tuple[np.ndarray, float]]:
    """(centre, facing) of every window slot on a facade whose outside is a street."""
    slots = []
    for box in boxes:
        (x0, z0), (x1, z1) = box.lo, box.hi
        # each face: a point on it, its outward normal, the direction along it and its length
        faces = (((x0, z1), (0, 1), (1, 0), x1 - x0, 0.0), ((x1, z0), (0, -1), (-1, 0), x1 - x0, 180.0),
                 ((x1, z0), (1, 0), (0, 1), z1 - z0, 90.0), ((x0, z1), (-1, 0), (0, -1), z1 - z0, -90.0))
        for start, normal, along, length, facing in faces:
            start, normal, along = (np.array(v, np.float64) for v in (start, normal, along))
            mid = start + 0.5 * length * along
            if not in_street(*(mid + 1.5 * normal)):
                continue
            columns = int((length - 0.4) / COLUMN)
            offset = 0.5 * (length - (columns - 1) * COLUMN)
            floors = int((box.height - 0.6 - FIRST_FLOOR) / FLOOR) + 1
            for c in range(columns):
                # a little in front of the wall, which would otherwise hide it in places
                xz = start + (offset + c * COLUMN) * along + 0.005 * normal
                for f in range(floors):
                    slots.append((np.array([xz[0], FIRST_FLOOR + f * FLOOR, xz[1]]), facing))
    return slots


def log_uniform(rng: np.random.Generator, n: int) -> np.ndarray:
    """n factors 10^(-3u), u uniform in [0, 1): log-uniform over three decades below 1."""
    return 10.0 ** (-DECADES * rng.random(n))


def street_lamps() -> list[np.ndarray]:
    """Lamp positions along both sides of every street, evenly spaced."""
    sides = []
    for axis, lo, hi in STREETS:
        for edge in (lo + 0.3, hi - 0.3):
            sides.append((axis, edge))
    spacing = len(sides) * 2 * HALF / N_SPOTS
    lamps = []
    for axis, edge in sides:
        for k in range(int(2 * HALF / spacing)):
            t = -HALF + (k + 0.5) * spacing
            x, z = (edge, t) if axis == "x" else (t, edge)
            lamps.append(np.array([x, 3.2, z]))
    return lamps[:N_SPOTS]


def fmt(v) -> str:
    return f"{float(v):.6g}"


def vec(v) -> str:
    return "[" + ", ".join(fmt(c) for c in v) + "]"


def make(rng: np.random.Generator):
    """(buildings, windows, spots, points) drawn from ``rng``: spots and points as (position or
    place, RGB intensity)."""
    boxes = buildings(rng)
    slots = window_slots(boxes)
    if len(slots) < N_WINDOWS:
        raise SystemExit(f"only {len(slots)} window slots for {N_WINDOWS} windows")
    picked = np.sort(rng.choice(len(slots), N_WINDOWS, replace=False))
    scale = log_uniform(rng, N_WINDOWS)
    tints = rng.integers(len(WINDOW_TINTS), size=N_WINDOWS)
    windows = [Window(slots[k][0], slots[k][1], tuple(WINDOW_RADIANCE * s * WINDOW_TINTS[c]))
               for k, s, c in zip(picked, scale, tints)]
    spots = [(p, tuple(SPOT_INTENSITY * s * SPOT_TINT))
             for p, s in zip(street_lamps(), log_uniform(rng, N_SPOTS))]
    # lanterns: where a random window slot of a street facade is, 2.2 above the pavement and
    # 0.25 out from the wall
    points = []
    for k, s in zip(rng.choice(len(slots), N_POINTS, replace=False), log_uniform(rng, N_POINTS)):
        centre, facing = slots[k]
        out = np.array([np.sin(np.radians(facing)), 0.0, np.cos(np.radians(facing))])
        points.append((np.array([centre[0], 2.2, centre[2]]) + 0.25 * out,
                       tuple(POINT_INTENSITY * s * POINT_TINT)))
    return boxes, windows, spots, points


def write_ply(path: Path) -> None:
    """The unit quad [-1, 1]^2 at z = 0 facing +z (Mitsuba's rectangle), as two triangles."""
    vertices = np.array([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], "<f4")
    header = ("ply\nformat binary_little_endian 1.0\nelement vertex 4\nproperty float x\n"
              "property float y\nproperty float z\nelement face 2\n"
              "property list uchar int vertex_indices\nend_header\n")
    path.write_bytes(header.encode() + vertices.tobytes() +
                     b"".join(struct.pack("<B3i", 3, *t) for t in ((0, 1, 2), (0, 2, 3))))


def write_toml(path: Path, boxes, windows, spots, points) -> None:
    lines = [
        "# A street grid at night (40 x 40): 5,000 lit windows (emissive quads on the facades that",
        "# face a street), 250 street lamps (spots pointing down) and 250 lanterns (point lights),",
        "# powers log-uniform over three decades, a very dim sky. Made by tools/make_many_lights.py",
        "# (seeded); the same scene in Mitsuba 3's format lies beside this file.",
        "[film]", f"width = {WIDTH}", f"height = {HEIGHT}", 'filter = "box"', "",
        "[camera]", f"fov = {FOV}",
        f"look_at = {{ origin = {vec(CAMERA['origin'])}, target = {vec(CAMERA['target'])}, "
        f"up = {vec(CAMERA['up'])} }}", "",
        "[integrator]", 'type = "path"', f"max_depth = {MAX_DEPTH}",
        "# the light BVH: many times power selection's efficiency here (RESULTS.md, Many lights)",
        "light_selection = \"bvh\"", "",
        "[sampler]", 'type = "sobol"', "spp = 64", ""]
    for name, value in MATERIALS.items():
        lines += [f"[materials.{name}]", f"reflectance = {vec(np.broadcast_to(value, 3))}"]
    lines += ["", "[[lights]]", 'type = "constant"', f"radiance = {vec(SKY)}", ""]
    for p, intensity in spots:
        lines += ["[[lights]]", 'type = "spot"', f"intensity = {vec(intensity)}",
                  "cutoff_angle = 60", "beam_width = 50",
                  f"transform = [{{ rotate = {{ axis = [1, 0, 0], angle = 90 }} }}, "
                  f"{{ translate = {vec(p)} }}]"]
    for p, intensity in points:
        lines += ["[[lights]]", 'type = "point"', f"intensity = {vec(intensity)}", f"position = {vec(p)}"]
    lines += ["", "[[shapes]]", 'name = "ground"', 'type = "rectangle"', 'material = "asphalt"',
              f"transform = [{{ scale = {fmt(HALF)} }}, {{ rotate = {{ axis = [1, 0, 0], angle = -90 }} }}]"]
    for k, b in enumerate(boxes):
        size = np.array([b.hi[0] - b.lo[0], b.height, b.hi[1] - b.lo[1]]) / 2
        centre = np.array([(b.lo[0] + b.hi[0]) / 2, b.height / 2, (b.lo[1] + b.hi[1]) / 2])
        lines += ["[[shapes]]", f'name = "building {k}"', 'type = "cube"', f'material = "{b.material}"',
                  f"transform = [{{ scale = {vec(size)} }}, {{ translate = {vec(centre)} }}]"]
    for w in windows:
        lines += ["[[shapes]]", 'type = "mesh"', 'file = "window.ply"', 'material = "window"',
                  f"emission = {{ radiance = {vec(w.radiance)} }}",
                  f"transform = [{{ scale = [{fmt(WINDOW_HALF[0])}, {fmt(WINDOW_HALF[1])}, 1] }}, "
                  f"{{ rotate = {{ axis = [0, 1, 0], angle = {fmt(w.facing)} }} }}, {{ translate = {vec(w.center)} }}]"]
    path.write_text("\n".join(lines) + "\n")


def xyz(v) -> str:
    return f'x="{fmt(v[0])}" y="{fmt(v[1])}" z="{fmt(v[2])}"'


def rgb(v) -> str:
    return ", ".join(fmt(c) for c in v)


def write_xml(path: Path, boxes, windows, spots, points) -> None:
    o, t, u = (", ".join(fmt(c) for c in CAMERA[k]) for k in ("origin", "target", "up"))
    lines = [
        "<!-- A street grid at night in Mitsuba 3's format, the same scene as the TOML file beside it",
        "     (made by tools/make_many_lights.py): 5,000 lit windows, 250 street lamps (spots) and",
        "     250 lanterns (points), powers log-uniform over three decades, a very dim sky. -->",
        '<scene version="3.0.0">',
        f'  <integrator type="path"><integer name="max_depth" value="{MAX_DEPTH}"/></integrator>',
        '  <sensor type="perspective">',
        f'    <float name="fov" value="{FOV}"/>',
        f'    <transform name="to_world"><lookat origin="{o}" target="{t}" up="{u}"/></transform>',
        '    <sampler type="independent"><integer name="sample_count" value="64"/></sampler>',
        '    <film type="hdrfilm">',
        f'      <integer name="width" value="{WIDTH}"/>',
        f'      <integer name="height" value="{HEIGHT}"/>',
        '      <rfilter type="box"/>',
        "    </film>",
        "  </sensor>"]
    for name, value in MATERIALS.items():
        lines.append(f'  <bsdf type="diffuse" id="{name}"><rgb name="reflectance" '
                     f'value="{rgb(np.broadcast_to(value, 3))}"/></bsdf>')
    lines.append(f'  <emitter type="constant"><rgb name="radiance" value="{rgb(SKY)}"/></emitter>')
    for p, intensity in spots:
        lines.append(f'  <emitter type="spot"><rgb name="intensity" value="{rgb(intensity)}"/>'
                     f'<float name="cutoff_angle" value="60"/><float name="beam_width" value="50"/>'
                     f'<transform name="to_world"><rotate x="1" angle="90"/><translate {xyz(p)}/>'
                     f"</transform></emitter>")
    for p, intensity in points:
        lines.append(f'  <emitter type="point"><rgb name="intensity" value="{rgb(intensity)}"/>'
                     f'<point name="position" {xyz(p)}/></emitter>')
    lines.append(f'  <shape type="rectangle" id="ground"><transform name="to_world"><scale value="{fmt(HALF)}"/>'
                 f'<rotate x="1" angle="-90"/></transform><ref id="asphalt"/></shape>')
    for k, b in enumerate(boxes):
        size = np.array([b.hi[0] - b.lo[0], b.height, b.hi[1] - b.lo[1]]) / 2
        centre = np.array([(b.lo[0] + b.hi[0]) / 2, b.height / 2, (b.lo[1] + b.hi[1]) / 2])
        lines.append(f'  <shape type="cube" id="building-{k}"><transform name="to_world">'
                     f"<scale {xyz(size)}/><translate {xyz(centre)}/></transform>"
                     f'<ref id="{b.material}"/></shape>')
    for w in windows:
        lines.append(f'  <shape type="ply"><string name="filename" value="window.ply"/>'
                     f'<transform name="to_world"><scale {xyz((*WINDOW_HALF, 1))}/>'
                     f'<rotate y="1" angle="{fmt(w.facing)}"/><translate {xyz(w.center)}/></transform>'
                     f'<ref id="window"/><emitter type="area"><rgb name="radiance" value="{rgb(w.radiance)}"/>'
                     f"</emitter></shape>")
    lines.append("</scene>")
    path.write_text("\n".join(lines) + "\n")


def write(folder: Path) -> tuple:
    """Write the scene's files into ``folder``; returns (buildings, windows, spots, points)."""
    folder.mkdir(parents=True, exist_ok=True)
    parts = make(np.random.default_rng(SEED))
    write_ply(folder / "window.ply")
    write_toml(folder / "scene.toml", *parts)
    write_xml(folder / "scene.xml", *parts)
    return parts


def main() -> None:
    boxes, windows, spots, points = write(OUT)
    print(f"wrote {OUT}: {len(boxes)} buildings, {len(windows)} windows, {len(spots)} spots, "
          f"{len(points)} points")


if __name__ == "__main__":
    main()
