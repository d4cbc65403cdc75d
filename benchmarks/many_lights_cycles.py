"""Blender Cycles' side of benchmarks/many_lights.py: builds the scene that benchmark describes
(world-space triangles with diffuse materials and one-sided emission, point and spot lights, a
constant background, a perspective camera) through bpy and renders it for a given time.
Run by Blender's Python module (``pip install bpy``, in its own Python 3.11 environment), not
by glrender's:

    BPY_PYTHON benchmarks/many_lights_cycles.py SCENE.npz LIGHT_TREE(0|1) SECONDS SEED OUT.npy

Prints one JSON line: seconds (sampling only: a 1-spp render's time, which holds Blender's
scene sync and BVH build, is subtracted), spp, the Blender version.

Matched to glrender and Mitsuba (checked against closed forms on this machine): a point light
of intensity I is Blender's power 4 pi I; a spot light has the same power factor, its cone is
Cycles' spot_size = 2 x cutoff, and its blend is chosen so that it emits what Mitsuba's (linear
in angle from beam_width to cutoff) emits; the one-sided area lights and diffuse surfaces are
the peers' recipe (../shared/peers/cycles_render.py): emission on the front only, black from
behind; max_bounces = max_depth - 2; the box filter of width 1.
"""
from __future__ import annotations

import json
import math
import sys
import time

import numpy as np

import bpy  # noqa: E402  (Blender's module: only in its own environment)
import mathutils  # noqa: E402


def spot_blend(cutoff: float, beam: float) -> float:
    """Cycles' spot_blend b for which its cone (smoothstep over cos theta in the outer b of
    [cos cutoff, 1]) emits the same power as Mitsuba's (1 inside beam, falling linearly in
    angle to 0 at cutoff): both integrals of the falloff over the solid angle equal."""
    theta = np.linspace(0.0, math.radians(cutoff), 100001)
    falloff = np.clip((math.radians(cutoff) - theta) / math.radians(cutoff - beam), 0.0, 1.0)
    mitsuba = float(np.sum(0.5 * (falloff[1:] * np.sin(theta[1:]) + falloff[:-1] * np.sin(theta[:-1])))
                    * (theta[1] - theta[0]))
    return 2.0 * (1.0 - mitsuba / (1.0 - math.cos(math.radians(cutoff))))


def material(name: str, reflectance, radiance=None, two_sided=False):
    m = bpy.data.materials.new(name)
    m.use_nodes = True
    nt = m.node_tree
    nt.nodes.clear()
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    diffuse = nt.nodes.new("ShaderNodeBsdfDiffuse")
    diffuse.inputs["Color"].default_value = (*reflectance, 1.0)
    diffuse.inputs["Roughness"].default_value = 0.0
    if radiance is None:
        nt.links.new(diffuse.outputs["BSDF"], out.inputs["Surface"])
        return m
    emission = nt.nodes.new("ShaderNodeEmission")
    emission.inputs["Color"].default_value = (*radiance, 1.0)
    emission.inputs["Strength"].default_value = 1.0
    add = nt.nodes.new("ShaderNodeAddShader")
    nt.links.new(diffuse.outputs["BSDF"], add.inputs[0])
    nt.links.new(emission.outputs["Emission"], add.inputs[1])
    if two_sided:
        nt.links.new(add.outputs["Shader"], out.inputs["Surface"])
        m.cycles.emission_sampling = "FRONT_BACK"
        return m
    # one-sided, as Mitsuba's area emitter and one-sided BSDF: black from behind
    geometry = nt.nodes.new("ShaderNodeNewGeometry")
    black = nt.nodes.new("ShaderNodeBsdfDiffuse")
    black.inputs["Color"].default_value = (0, 0, 0, 1)
    mix = nt.nodes.new("ShaderNodeMixShader")
    nt.links.new(geometry.outputs["Backfacing"], mix.inputs["Fac"])
    nt.links.new(add.outputs["Shader"], mix.inputs[1])
    nt.links.new(black.outputs["BSDF"], mix.inputs[2])
    nt.links.new(mix.outputs["Shader"], out.inputs["Surface"])
    m.cycles.emission_sampling = "FRONT"
    return m


def build(d, meta: dict) -> None:
    """The scene of ``d`` (the arrays of the .npz) in an empty Blender scene."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    sc = bpy.context.scene
    # one mesh, a material slot per (material, emission) pair: each lit window has its own
    # constant emission, which Cycles' light tree reads as that triangle's power
    keys = np.concatenate([d["material"][:, None].astype(np.float64), d["emission"],
                           d["two_sided"][:, None].astype(np.float64)], axis=1)
    unique, slot = np.unique(keys, axis=0, return_inverse=True)
    me = bpy.data.meshes.new("scene")
    me.from_pydata([tuple(p) for p in d["positions"].reshape(-1, 3)], [],
                   [(3 * k, 3 * k + 1, 3 * k + 2) for k in range(len(d["positions"]))])
    for k, key in enumerate(unique):
        reflectance = d["reflectance"][int(key[0])]
        radiance = tuple(key[1:4]) if key[1:4].any() else None
        me.materials.append(material(f"m{k}", reflectance, radiance, bool(key[4])))
    me.polygons.foreach_set("material_index", slot.astype(np.int32).ravel())
    me.update()
    sc.collection.objects.link(bpy.data.objects.new("scene", me))

    def light(kind, name, world, intensity):
        data = bpy.data.lights.new(name, kind)
        scale = max(intensity)
        data.color = tuple(c / scale for c in intensity)
        data.energy = 4.0 * math.pi * scale
        data.shadow_soft_size = 0.0
        data.use_soft_falloff = False
        obj = bpy.data.objects.new(name, data)
        obj.matrix_world = mathutils.Matrix([list(r) for r in world])
        sc.collection.objects.link(obj)
        return data

    for k, (p, intensity) in enumerate(zip(d["point_position"], d["point_intensity"])):
        world = np.eye(4)
        world[:3, 3] = p
        light("POINT", f"point{k}", world, intensity)
    cutoff, beam = (float(v) for v in d["spot_angles"]) if len(d["spot_world"]) else (0.0, 0.0)
    for k, (W, intensity) in enumerate(zip(d["spot_world"], d["spot_intensity"])):
        # Blender's spot shines along its local -z, glrender's and Mitsuba's along +z
        data = light("SPOT", f"spot{k}", W @ np.diag([-1.0, 1.0, -1.0, 1.0]), intensity)
        data.spot_size = math.radians(2 * cutoff)
        data.spot_blend = spot_blend(cutoff, beam)

    # the camera: Mitsuba's looks along +z with +x to the image's left, Blender's along -z
    cam = bpy.data.cameras.new("camera")
    cam.sensor_fit = {"x": "HORIZONTAL", "y": "VERTICAL"}[meta["fov_axis"]]
    cam.angle = math.radians(meta["fov"])
    cam.clip_start, cam.clip_end = 1e-3, 1e4
    obj = bpy.data.objects.new("camera", cam)
    obj.matrix_world = mathutils.Matrix([list(r) for r in d["camera"] @ np.diag([-1.0, 1.0, -1.0, 1.0])])
    sc.collection.objects.link(obj)
    sc.camera = obj

    world = bpy.data.worlds.new("sky")
    world.use_nodes = True
    world.node_tree.nodes["Background"].inputs["Color"].default_value = (*meta["background"], 1.0)
    world.node_tree.nodes["Background"].inputs["Strength"].default_value = 1.0
    sc.world = world

    r = sc.render
    r.engine = "CYCLES"
    r.resolution_x, r.resolution_y, r.resolution_percentage = meta["width"], meta["height"], 100
    r.threads_mode = "FIXED"
    r.threads = meta["threads"]
    r.use_compositing = r.use_sequencer = False
    r.image_settings.file_format = "OPEN_EXR"
    r.image_settings.color_depth = "32"
    r.image_settings.color_mode = "RGB"
    sc.view_settings.view_transform = "Standard"
    sc.view_settings.look = "None"
    c = sc.cycles
    c.device = "CPU"
    c.use_adaptive_sampling = c.use_denoising = False
    c.max_bounces = c.diffuse_bounces = c.glossy_bounces = c.transmission_bounces = meta["max_depth"] - 2
    c.transparent_max_bounces = meta["max_depth"] - 2
    c.volume_bounces = 0
    c.sample_clamp_direct = c.sample_clamp_indirect = 0.0
    c.light_sampling_threshold = 0.0
    c.pixel_filter_type = "BOX"
    c.filter_width = 1.0
    c.time_limit = 0.0


def render(spp: int) -> float:
    bpy.context.scene.cycles.samples = spp
    t0 = time.perf_counter()
    bpy.ops.render.render()
    return time.perf_counter() - t0


def main() -> None:
    scene, tree, seconds, seed, out = sys.argv[1:6]
    d = dict(np.load(scene))
    meta = json.loads(str(d.pop("meta")))
    build(d, meta)
    c = bpy.context.scene.cycles
    c.use_light_tree = tree == "1"
    c.seed = int(seed)
    setup = render(1)    # the first render compiles the shaders: once more for the setup alone
    setup = render(1)
    # Cycles' time_limit does not say how many samples it reached: calibrate the rate, then
    # render the sample count that fills the time
    rate = 15 / max(render(16) - setup, 1e-3)
    spp = max(2, int(round(float(seconds) * rate)) + 1)
    t = render(spp) - setup
    path = out[:-4] + ".exr"
    bpy.data.images["Render Result"].save_render(path)
    image = bpy.data.images.load(path)
    px = np.empty(meta["width"] * meta["height"] * image.channels, np.float32)
    image.pixels.foreach_get(px)
    img = px.reshape(meta["height"], meta["width"], image.channels)[::-1, :, :3]  # bottom row first
    np.save(out, img)
    print(json.dumps({"seconds": t, "spp": spp - 1, "version": bpy.app.version_string,
                      "setup_s": setup}))


if __name__ == "__main__":
    main()
