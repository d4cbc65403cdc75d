"""The glrender command line: argument parsing only; the work lives in the package.

Every user error is a :class:`~glrender.errors.GlrenderError`, printed on one line
to stderr with exit code 2. Ctrl-C exits with 130.
"""
from __future__ import annotations

import argparse
import json
import sys

from .errors import GlrenderError


def _add_device(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--device", default=None, metavar="auto|cpu|gpu|N",
                        help="EGL device: auto (a GPU if present, else llvmpipe), cpu, gpu or an "
                             "index (default: $GLRENDER_DEVICE or auto)")
    parser.add_argument("--threads", type=int, default=None, metavar="N",
                        help="llvmpipe worker threads (default: all cores; $LP_NUM_THREADS)")


def cmd_info(args) -> int:
    from .gl import egl
    from .gl.context import create_context

    devices = [{"index": d.index, "kind": d.kind, "drm_file": d.drm_file,
                "extensions": list(d.extensions)} for d in egl.list_devices()]
    ctx = create_context(args.device, threads=args.threads)
    info = ctx.info()
    info["devices"] = devices
    if args.json:
        print(json.dumps(info, indent=2))
        return 0
    print("EGL devices:")
    for d in egl.list_devices():
        mark = "*" if d.index == ctx.device.index else " "
        print(f" {mark} {d.describe()}")
    print(f"chosen device:   #{ctx.device.index} ({ctx.device.kind}, choice {info['device']['choice']})")
    print(f"GL_RENDERER:     {info['GL_RENDERER']}")
    print(f"GL_VERSION:      {info['GL_VERSION']}")
    print(f"GL_VENDOR:       {info['GL_VENDOR']}")
    if info["llvmpipe_threads"] is not None:
        print(f"llvmpipe threads: {info['llvmpipe_threads']}")
    print(f"shader cache:    {info['shader_cache']}")
    print("limits:")
    for key, value in info["limits"].items():
        print(f"  {key:42s} {value}")
    print("extensions:")
    for key, value in info["extensions"].items():
        print(f"  {key:42s} {'yes' if value else 'no'}")
    return 0


class _Progress:
    """A one-line progress bar on stderr: spp done/total, samples/s, elapsed, ETA."""

    def __init__(self, total: int, pixels: int, enabled: bool):
        import time

        self.total, self.pixels, self.enabled = total, pixels, enabled and sys.stderr.isatty()
        self.start = time.perf_counter()
        self._time = time.perf_counter

    def __call__(self, done: int, total: int) -> None:
        if not self.enabled:
            return
        elapsed = self._time() - self.start
        rate = done * self.pixels / max(elapsed, 1e-9)
        eta = (total - done) * elapsed / max(done, 1)
        width = 30
        filled = int(width * done / max(total, 1))
        sys.stderr.write(f"\r[{'#' * filled}{'.' * (width - filled)}] {done}/{total} spp  "
                         f"{rate / 1e6:.2f} Msamples/s  {elapsed:.1f}s  ETA {eta:.1f}s ")
        sys.stderr.flush()

    def close(self) -> None:
        if self.enabled:
            sys.stderr.write("\n")


def cmd_render(args) -> int:
    import time

    from . import load
    from .errors import UsageError
    from .film.io import HDR_FORMATS, LDR_FORMATS
    from .gl.context import create_context
    from .render.renderer import Renderer, settings_from_scene

    output = args.output
    ext = "." + output.rsplit(".", 1)[-1].lower() if "." in output else ""
    if ext not in LDR_FORMATS + HDR_FORMATS or ext == ".hdr":
        raise UsageError(f"{output}: unsupported output format {ext or '(none)'} "
                         f"(expected .png, .jpg, .exr, .pfm or .npy)")
    scene = load(args.scene)
    if args.width is not None:
        scene.film.width = args.width
    if args.height is not None:
        scene.film.height = args.height
    scene.film.__post_init__()
    settings = settings_from_scene(scene, integrator=args.integrator, spp=args.spp, seed=args.seed,
                                   sampler=args.sampler, max_depth=args.max_depth,
                                   strategy=args.strategy, aovs=bool(args.aov))
    ctx = create_context(args.device, threads=args.threads)
    t0 = time.perf_counter()
    renderer = Renderer(scene, settings, ctx=ctx)
    setup = time.perf_counter() - t0
    progress = _Progress(settings.sampler.spp, scene.film.width * scene.film.height, not args.quiet)
    t1 = time.perf_counter()
    try:
        renderer.step(settings.sampler.spp, callback=progress)
    finally:
        progress.close()
    seconds = time.perf_counter() - t1
    film = renderer.film()
    film.save(output)
    paths = film.spp * scene.film.width * scene.film.height
    stats = {"scene": str(args.scene), "output": output, "spp": film.spp,
             "width": scene.film.width, "height": scene.film.height,
             "integrator": settings.integrator.kind, "sampler": settings.sampler.kind,
             "seed": settings.sampler.seed, "max_depth": settings.integrator.max_depth,
             "render_seconds": seconds, "setup_seconds": setup,
             "mpaths_per_second": paths / seconds / 1e6 if seconds > 0 else None,
             "nonfinite_samples": film.nonfinite_total, "mean": [float(v) for v in film.mean.reshape(-1, 3).mean(0)],
             "device": ctx.renderer, "gl_version": ctx.gl.info["GL_VERSION"]}
    if args.stats:
        with open(args.stats, "w") as f:
            json.dump(stats, f, indent=2)
    if not args.quiet:
        print(f"{film.spp} spp in {seconds:.2f} s ({stats['mpaths_per_second']:.2f} Mpaths/s), "
              f"{film.nonfinite_total} non-finite samples dropped -> {output}", file=sys.stderr)
    renderer.release()
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="glrender",
        description="A physically based renderer whose Monte Carlo core runs as GLSL compute "
                    "shaders (Mesa llvmpipe or a GPU, through EGL).")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True

    p = sub.add_parser("info", help="list EGL devices, the chosen one and its limits",
                       description="List the EGL devices, the chosen device, GL_RENDERER, "
                                   "version, the limits the renderer relies on, llvmpipe's "
                                   "thread count and the shader cache location.")
    _add_device(p)
    p.add_argument("--json", action="store_true", help="print the report as JSON")
    p.set_defaults(func=cmd_info)

    p = sub.add_parser("render", help="render a scene file to an image",
                       description="Render SCENE to an image. Options override the scene "
                                   "file's settings. The output format follows the extension: "
                                   ".png/.jpg (sRGB, tonemapped by clamping), .exr (float, with "
                                   "AOV layers), .pfm, .npy (float32 linear RGB).")
    p.add_argument("scene", help="scene file (.toml)")
    p.add_argument("-o", "--output", default="render.png", help="output image (default render.png)")
    p.add_argument("--spp", type=int, default=None, help="samples per pixel")
    p.add_argument("--integrator", choices=("path", "direct", "ao"), default=None)
    p.add_argument("--sampler", choices=("independent", "stratified", "sobol"), default=None)
    p.add_argument("--strategy", choices=("light", "bsdf", "mis-balance", "mis-power"), default=None,
                   help="direct-lighting strategy / MIS heuristic")
    p.add_argument("--max-depth", type=int, default=None,
                   help="path segments: 1 = emitters seen directly, 2 = direct light, -1 = unbounded")
    p.add_argument("--width", type=int, default=None)
    p.add_argument("--height", type=int, default=None)
    p.add_argument("--seed", type=int, default=None)
    p.add_argument("--aov", default=None, metavar="albedo,normal,depth",
                   help="also accumulate first-hit AOVs (written as EXR layers)")
    p.add_argument("--stats", default=None, metavar="FILE.json", help="write render statistics")
    p.add_argument("--quiet", action="store_true", help="print nothing but errors")
    p.add_argument("--debug", action="store_true", help="show full error messages")
    _add_device(p)
    p.set_defaults(func=cmd_render)

    # -- glrender sampling: pictures of every warp and their chi-square table ---------------
    def cmd_sampling(args) -> int:
        from pathlib import Path

        from .errors import UsageError
        from .sampling.plots import write_sampling_plots

        if args.samples < 1000:
            raise UsageError(f"--samples {args.samples}: the chi-square tests need at least 1000")
        write_sampling_plots(args.out, seed=args.seed, sample_count=args.samples)
        print(Path(args.out).resolve())
        return 0

    p = sub.add_parser("sampling", help="plot the sampling warps and tabulate their chi-square tests",
                       description="Write one PNG per 2D warp of the GLSL sampling library (the "
                                   "warp applied to independent and to jittered-grid points), "
                                   "disks.png (the four disk warps) and chi2.md (each warp's "
                                   "chi-square p-value), then print the folder.")
    p.add_argument("--out", required=True, metavar="DIR", help="output folder (created if missing)")
    p.add_argument("--seed", type=int, default=0, help="seed of the plotted and tested points")
    p.add_argument("--samples", type=int, default=1_000_000, metavar="N",
                   help="chi-square samples per warp (default 10^6)")
    p.set_defaults(func=cmd_sampling)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except GlrenderError as exc:
        message = str(exc) if getattr(args, "debug", False) else str(exc).splitlines()[0]
        print(f"glrender: error: {message}", file=sys.stderr)
        return exc.exit_code
    except KeyboardInterrupt:
        print("glrender: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:  # output piped into `head` and the like
        import os
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
