"""The ``glrender preview`` command: options -> scene, window, frame loop."""
from __future__ import annotations

import argparse
import math
from pathlib import Path

from ..errors import UsageError
from ..preview.keys import help_text

DESCRIPTION = """\
Open SCENE in a window and watch it converge: every frame adds the samples that fit
in the frame budget (~30 ms) and shows the running mean, tonemapped on the device.
Moving the camera restarts the accumulation; keys switch the integrator, the
direct-lighting strategy, the max depth and the view (color or the albedo, normal
and variance AOVs). The title shows the settings, spp and samples per second.

Needs a display (X11 or Wayland) and the glfw package (pip install 'glrender[preview]').
Without a display: `glrender render SCENE -o image.png`, or `xvfb-run -a glrender preview SCENE`."""


def epilog() -> str:
    return ("keys and mouse:\n" + help_text() + "\n\n"
            "Screenshots go to --screenshot-dir as NAME-NNN.png (the view as shown), .exr (the\n"
            "accumulation: RGB, variance, albedo, normal, depth; .pfm without OpenEXR) and .json\n"
            "(settings, spp and camera matrix).\n\n"
            "exit codes: 0 window closed, 2 error (one line on stderr), 130 Ctrl-C.")


def add_preview_parser(sub) -> None:
    """Add the ``preview`` subcommand to the CLI's subparsers."""
    from ..film.tonemap import TONE_CURVES
    from ..render.params import STRATEGIES
    from ..scene.model import INTEGRATORS, LIGHT_SELECTIONS, SAMPLER_KINDS
    from ..preview.display import VIEWS

    p = sub.add_parser("preview", help="open a scene in a window and steer it while it renders",
                       description=DESCRIPTION, epilog=epilog(),
                       formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("scene", help="scene file")
    g = p.add_argument_group("image and light transport")
    g.add_argument("--width", type=int, default=None, metavar="W",
                   help="image width in pixels (alone: the height keeps the scene's aspect ratio)")
    g.add_argument("--height", type=int, default=None, metavar="H",
                   help="image height in pixels (alone: the width keeps the scene's aspect ratio)")
    g.add_argument("--integrator", choices=INTEGRATORS, default=None,
                   help="first integrator (default: the scene's; key I switches)")
    g.add_argument("--strategy", choices=tuple(STRATEGIES), default=None,
                   help="first direct-lighting strategy (default: the scene's; key M switches)")
    g.add_argument("--light-selection", choices=LIGHT_SELECTIONS, default=None,
                   help="how light samples choose a light: auto (uniformly below 64 lights, by "
                        "power from 64), uniformly, by power, or by a light BVH (default: the scene's)")
    g.add_argument("--max-depth", type=int, default=None, metavar="N",
                   help="first max depth: path segments, -1 unbounded up to a cap of 256, bdpt 16 "
                        "(keys [ and ] change it)")
    g.add_argument("--sampler", choices=SAMPLER_KINDS, default=None,
                   help="sample generator (default: the scene's)")
    g.add_argument("--seed", type=int, default=None, metavar="S", help="seed (default: the scene's)")
    g.add_argument("--spp", type=int, default=None, metavar="N",
                   help="stop adding samples at N per pixel (default: never)")
    g.add_argument("-D", dest="define", action="append", default=[], metavar="KEY=VALUE",
                   help="set the scene parameter $KEY (repeatable)")
    g = p.add_argument_group("display")
    g.add_argument("--view", choices=VIEWS, default="color", help="first view (default color)")
    g.add_argument("--exposure", type=float, default=0.0, metavar="STOPS",
                   help="scale by 2^STOPS before the tone curve (default 0)")
    g.add_argument("--tonemap", choices=TONE_CURVES, default="clamp",
                   help="tone curve: clamp (default), filmic (Hable) or aces (Hill's fit)")
    g.add_argument("--frame-budget", type=float, default=30.0, metavar="MS",
                   help="milliseconds per frame (rendering and display; default 30)")
    g = p.add_argument_group("outputs")
    g.add_argument("--screenshot-dir", default=".", metavar="DIR",
                   help="folder for screenshots, created if missing (key P; default: the "
                        "current folder)")
    g.add_argument("--record", default=None, metavar="DIR",
                   help="also save every displayed frame as DIR/frame-NNNNNN.png (DIR created "
                        "if missing)")
    g = p.add_argument_group("device and messages")
    g.add_argument("--device", default=None, metavar="auto|cpu|gpu",
                   help="auto: the display's OpenGL driver; cpu: Mesa's llvmpipe; gpu: refuse "
                        "llvmpipe (default: $GLRENDER_DEVICE or auto)")
    g.add_argument("--threads", type=int, default=None, metavar="N",
                   help="llvmpipe worker threads (default: all cores; $LP_NUM_THREADS)")
    g.add_argument("--debug", action="store_true", help="show the traceback of errors")
    p.set_defaults(func=run_preview)


def _check(args) -> None:
    def need(name, value, ok, what):
        if value is not None and not ok(value):
            raise UsageError(f"{name} {value}: expected {what}")

    need("--width", args.width, lambda v: 1 <= v <= 65536, "pixels in 1..65536")
    need("--height", args.height, lambda v: 1 <= v <= 65536, "pixels in 1..65536")
    need("--spp", args.spp, lambda v: 1 <= v < 1 << 31, "a positive number of samples per pixel")
    need("--seed", args.seed, lambda v: 0 <= v < 1 << 32, "an integer in 0..2^32-1")
    need("--max-depth", args.max_depth, lambda v: v == -1 or v >= 1,
         "-1 (unbounded) or a number of path segments >= 1")
    need("--exposure", args.exposure, math.isfinite, "a finite number of stops")
    need("--frame-budget", args.frame_budget, lambda v: math.isfinite(v) and 1 <= v <= 10000,
         "milliseconds in 1..10000")
    need("--threads", args.threads, lambda v: v >= 1, "a positive number of threads")


def _folder(path: str, option: str, what: str) -> Path:
    """The folder of ``option``, created if missing and probed (a file written there and
    removed), before the window opens."""
    from ..film.io import check_writable

    return check_writable(path, what, option, folder=True)


def scene_name(path: Path) -> str:
    """A short name for titles and screenshots: the file's stem, or its folder's name
    for the usual ``FOLDER/scene.toml``."""
    return path.parent.name if path.stem == "scene" and path.parent.name else path.stem


def run_preview(args) -> int:
    """Run ``glrender preview`` with parsed ``args``; returns the exit code."""
    from .. import load
    from ..gl.context import create_window_context
    from .options import check_scene_file, parse_defines
    from ..preview.app import PreviewApp, PreviewOptions
    from ..preview.display import DisplaySettings

    _check(args)
    params = parse_defines(args.define)
    scene_path = Path(args.scene)
    check_scene_file(scene_path)
    screenshots = _folder(args.screenshot_dir, "--screenshot-dir", "screenshots")
    record = _folder(args.record, "--record", "recorded frames") if args.record else None
    # the window first: without a display this fails before the scene is loaded
    name = scene_name(scene_path)
    ctx = create_window_context(512, 512, f"glrender - {name}", device=args.device,
                                threads=args.threads, visible=False)
    import glfw

    app = None
    try:
        scene = load(scene_path, **params)
        scene.film = scene.film.resized(args.width, args.height)
        options = PreviewOptions(
            scene_name=name, integrator=args.integrator, strategy=args.strategy,
            light_selection=args.light_selection,
            max_depth=args.max_depth, sampler=args.sampler, seed=args.seed, spp=args.spp,
            display=DisplaySettings(view=args.view, exposure=args.exposure, curve=args.tonemap),
            frame_budget=args.frame_budget / 1000.0, screenshot_dir=screenshots, record_dir=record)
        glfw.set_window_size(ctx.window, *_window_size(glfw, (scene.film.width, scene.film.height)))
        glfw.show_window(ctx.window)
        app = PreviewApp(scene, ctx, options)
        return app.run()
    finally:
        if app is not None:
            app.release()
        glfw.destroy_window(ctx.window)
        glfw.terminate()


def _window_size(glfw, image: tuple[int, int]) -> tuple[int, int]:
    """The window's first size for an image, within the primary monitor."""
    from ..preview.app import window_size_for

    monitor = glfw.get_primary_monitor()
    mode = glfw.get_video_mode(monitor) if monitor else None
    return window_size_for(image, (mode.size.width, mode.size.height) if mode else None)
