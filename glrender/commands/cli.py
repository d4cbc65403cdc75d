"""The glrender command line: argument parsing, error reporting and signals.

Every user error is a :class:`~glrender.errors.GlrenderError` (a bad option value
included), printed as one line on stderr with exit code 2; ``--debug`` adds the
traceback. SIGINT and SIGTERM during a render stop it after the current dispatch,
write what was rendered and a checkpoint, and exit with 130 and 143; elsewhere they
stop at once with the same codes. The render command itself lives in
:mod:`glrender.commands.render`.
"""
from __future__ import annotations

import argparse
import json
import signal
import sys
import warnings

from ..errors import GlrenderError


class Interrupted(KeyboardInterrupt):
    """A stop signal (SIGINT or SIGTERM) that ends the command at once."""

    def __init__(self, signum: int):
        super().__init__(signal.Signals(signum).name)
        self.signum = signum


class StopSignals:
    """SIGINT and SIGTERM handlers for the whole command.

    Outside :meth:`deferred` a signal raises :class:`Interrupted` at once (nothing is
    lost during loading and compiling). Inside it, the first signal only sets
    :attr:`received` (the render loop asks :meth:`requested` between dispatches and
    stops cleanly); a second one raises :class:`Interrupted` (quit without saving).
    """

    SIGNALS = (signal.SIGINT, signal.SIGTERM)

    def __init__(self):
        self.received: int | None = None
        self._defer = False
        self._saved = {}

    def install(self) -> "StopSignals":
        import threading

        if threading.current_thread() is threading.main_thread():   # signal.signal's rule
            for signum in self.SIGNALS:
                self._saved[signum] = signal.signal(signum, self._handle)
        return self

    def uninstall(self) -> None:
        for signum, handler in self._saved.items():
            signal.signal(signum, handler)
        self._saved = {}

    def _handle(self, signum, frame):
        first = self.received is None
        if first:
            self.received = signum
        if not (self._defer and first):
            raise Interrupted(signum)

    def requested(self) -> bool:
        return self.received is not None

    def defer(self, on: bool = True) -> None:
        self._defer = on


class _Parser(argparse.ArgumentParser):
    """argparse, with usage errors on one line (exit 2) like every other error."""

    def error(self, message: str):
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


# -- glrender info --------------------------------------------------------------------------
def cmd_info(args) -> int:
    from ..gl import egl
    from ..gl.context import create_context
    from ..gpu.capacity import reference_capacity

    devices = [{"index": d.index, "kind": d.kind, "drm_file": d.drm_file,
                "extensions": list(d.extensions)} for d in egl.list_devices()]
    ctx = create_context(args.device, threads=args.threads)
    info = ctx.info()
    info["devices"] = devices
    info["mesh"] = reference_capacity(ctx.gl)
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
    print(f"traversal:       {info['traversal']}")
    print(f"shader cache:    {info['shader_cache']}")
    print("limits:")
    for key, value in info["limits"].items():
        print(f"  {key:42s} {value}")
    mesh = info["mesh"]
    print(f"BVH triangles:   {mesh['bytes_per_triangle']:.0f} device bytes per triangle (a "
          f"{mesh['triangles']:,}-triangle reference mesh; a scene's own: --stats), at most "
          f"{mesh['max_triangles']:,} triangles (their {mesh['limited_by']} then fill the "
          f"{mesh['textures']} buffer textures of GL_MAX_TEXTURE_BUFFER_SIZE texels glrender "
          "binds for them)")
    print("extensions:")
    for key, value in info["extensions"].items():
        print(f"  {key:42s} {'yes' if value else 'no'}")
    return 0


# -- glrender sampling ----------------------------------------------------------------------
def cmd_sampling(args) -> int:
    from pathlib import Path

    from ..errors import UsageError
    from ..sampling.plots import write_sampling_plots

    from ..film.io import check_writable

    if args.samples < 1000:
        raise UsageError(f"--samples {args.samples}: the chi-square tests need at least 1000")
    check_writable(args.out, "sampling plots", "--out", folder=True)
    write_sampling_plots(args.out, seed=args.seed, sample_count=args.samples)
    print(Path(args.out).resolve())
    return 0


# -- glrender lab / compare (glrender/lab/) ---------------------------------------------------
def cmd_lab(args) -> int:
    from .lab import run_lab_command

    return run_lab_command(args)


def cmd_compare(args) -> int:
    from .compare import run_compare_command

    return run_compare_command(args)


# -- glrender render ------------------------------------------------------------------------
def cmd_render(args) -> int:
    from .render import run_render

    return run_render(args, args.signals)


RENDER_DESCRIPTION = """\
Render SCENE to an image. Options override the scene file's settings; -D fills the
scene's $parameters. The output format follows the extension of -o:
  .exr  float32 (or --half) with a variance layer and the --aov layers (OpenEXR package)
  .pfm  float32 RGB; .hdr  Radiance RGBE; .npy  float32 (H, W, 3) numpy array
  .png, .jpg  8-bit: --exposure, then --tonemap, then sRGB (unless --no-srgb)
AOVs of formats without layers go beside the image as OUT-STEM.NAME.pfm (.npy for .npy).

The render runs in passes of a few samples per pixel. --time stops at a budget in
whole passes. Ctrl-C (SIGINT) or SIGTERM stops after the current dispatch (well under
a second), writes the image so far and a checkpoint, and exits with 130 or 143; a
second Ctrl-C quits without writing. The image so far never replaces one already at
OUT: it goes beside it, as OUT-STEM.partial.EXT. --resume continues from the
checkpoint: the final image is bitwise the one an uninterrupted render gives (same
device); options not given are taken from the checkpoint, and a checkpoint of another
scene or other settings is refused. A render without --resume does not start while
its checkpoint is there (--overwrite replaces it)."""

RENDER_EPILOG = """\
examples:
  glrender render scenes/cornell-box/scene.toml -o cornell.exr --spp 256 --aov albedo,normal
  glrender render scene.toml -o out.png --time 60 --tonemap aces --exposure 1
  glrender render scene.toml -o out.exr --spp 4096 --checkpoint-every 300
  glrender render scene.toml -o out.exr --resume        # after Ctrl-C
  glrender render scene.xml -D roughness=0.2 -o rough.exr
  glrender render scene.toml -o out.exr --spp 16 --denoise   # out.exr + out.denoised.exr

exit codes: 0 done, 2 error (one line on stderr; --debug adds the traceback),
130 stopped by SIGINT, 143 stopped by SIGTERM."""


def _add_device(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--device", default=None, metavar="auto|cpu|gpu|N",
                        help="EGL device: auto (a GPU if present, else llvmpipe), cpu, gpu or an "
                             "index from `glrender info` (default: $GLRENDER_DEVICE or auto)")
    parser.add_argument("--threads", type=int, default=None, metavar="N",
                        help="llvmpipe worker threads (default: all cores; $LP_NUM_THREADS)")


def _add_render(sub) -> None:
    from ..film.tonemap import TONE_CURVES
    from .options import AOV_NAMES, add_search_path
    from ..render.params import STRATEGIES
    from ..scene.model import INTEGRATORS, LIGHT_SELECTIONS, SAMPLER_KINDS

    p = sub.add_parser("render", help="render a scene file to an image",
                       description=RENDER_DESCRIPTION, epilog=RENDER_EPILOG,
                       formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("scene", help="scene file")
    p.add_argument("-o", "--output", default="render.png", metavar="OUT",
                   help="output image; the extension picks the format (default: render.png)")
    g = p.add_argument_group("samples")
    g.add_argument("--spp", type=int, default=None, metavar="N",
                   help="samples per pixel (default: the scene's)")
    g.add_argument("--time", type=float, default=None, metavar="SECONDS",
                   help="render for this long, in whole passes (with --spp: whichever ends first)")
    g.add_argument("--sampler", choices=SAMPLER_KINDS, default=None,
                   help="sample generator (default: the scene's)")
    g.add_argument("--seed", type=int, default=None, metavar="S",
                   help="seed: the same seed gives the same image")
    g.add_argument("--noise-threshold", type=float, default=None, metavar="R",
                   help="render as many samples as make the mean relative standard error R "
                        "(e.g. 0.02), predicted by an independent 32-spp pilot so the image "
                        "stays unbiased; --spp caps it")
    g.add_argument("--clamp", type=float, default=None, metavar="L",
                   help="scale down samples whose largest RGB component exceeds L (removes "
                        "fireflies; biased, marked in --stats; default: off)")
    g = p.add_argument_group("light transport")
    g.add_argument("--integrator", choices=INTEGRATORS, default=None,
                   help="path tracer, direct lighting, ambient occlusion, light tracing, bidirectional, "
                        "SPPM or photon mapping (default: the scene's)")
    g.add_argument("--strategy", choices=tuple(STRATEGIES), default=None,
                   help="direct-lighting strategy: light or BSDF sampling alone, or both with "
                        "the balance or power heuristic")
    g.add_argument("--light-selection", choices=LIGHT_SELECTIONS, default=None,
                   help="how light samples choose a light: auto (uniformly below 64 lights, by "
                        "power from 64), uniformly, by power, or by a light BVH at the shading "
                        "point (path, direct, and the camera paths of sppm and photon; light "
                        "paths choose by power; default: the scene's, auto)")
    g.add_argument("--max-depth", type=int, default=None, metavar="N",
                   help="path segments: 1 = emitters seen directly, 2 = direct light, "
                        "-1 = unbounded, up to a cap: 256 segments, bdpt 16 (the summary line "
                        "and --stats count the paths a cap cut short)")
    g.add_argument("--rr", default=None, metavar="throughput|fixed:Q|off",
                   help="Russian roulette of path, lighttrace and bdpt: survive with "
                        "min(throughput, 0.95) (default), with a fixed probability Q, or never "
                        "(off at --max-depth -1: bdpt stops at 16 segments, the others at 256)")
    g.add_argument("--rr-depth", type=int, default=None, metavar="K",
                   help="path segments before Russian roulette starts (default: the scene's, 5)")
    g.add_argument("--light-samples", type=int, default=None, metavar="N",
                   help="path tracer: light samples (shadow rays) at every vertex (default 1)")
    g.add_argument("--split", type=int, default=None, metavar="N",
                   help="path tracer: BSDF branches at the first vertex (default 1)")
    from .photon_options import add_arguments as add_photon_arguments

    add_photon_arguments(p)
    g = p.add_argument_group("scene")
    g.add_argument("--width", type=int, default=None, metavar="W",
                   help="image width in pixels (alone: the height keeps the scene's aspect ratio)")
    g.add_argument("--height", type=int, default=None, metavar="H",
                   help="image height in pixels (alone: the width keeps the scene's aspect ratio)")
    g.add_argument("--crop", default=None, metavar="X0,Y0,X1,Y1",
                   help="render only pixels X0 <= x < X1, Y0 <= y < Y1 of the film; they equal "
                        "the same pixels of a full render bitwise")
    g.add_argument("-D", dest="define", action="append", default=[], metavar="KEY=VALUE",
                   help="set the scene parameter $KEY (repeatable)")
    add_search_path(g)
    g = p.add_argument_group("outputs")
    g.add_argument("--aov", default=None, metavar=",".join(AOV_NAMES),
                   help="also write these arbitrary output variables: first-hit albedo, "
                        "normal and depth, the emission seen, and the per-sample variance")
    g.add_argument("--exposure", type=float, default=0.0, metavar="STOPS",
                   help="PNG/JPEG: scale by 2^STOPS before the tone curve (default 0)")
    g.add_argument("--tonemap", choices=TONE_CURVES, default="clamp",
                   help="PNG/JPEG tone curve: clamp (default), filmic (Hable) or aces (Hill's fit)")
    g.add_argument("--srgb", action=argparse.BooleanOptionalAction, default=True,
                   help="PNG/JPEG: sRGB encoding (default), or linear 8-bit with --no-srgb")
    g.add_argument("--half", action="store_true", help="EXR: half floats instead of float32")
    g.add_argument("--denoise", action="store_true",
                   help="also write OUT.denoised.EXT denoised by Open Image Denoise (and a "
                        "denoised layer in an EXR); the image itself stays unbiased "
                        "(extra: glrender[denoise])")
    g.add_argument("--strategy-images", default=None, metavar="DIR",
                   help="bdpt: also write the weighted and unweighted image of every strategy "
                        "(s, t) of path lengths up to --strategy-depth as labelled pyramids "
                        "(DIR/weighted.png, DIR/unweighted.png) and floats (DIR/strategies.npz)")
    g.add_argument("--strategy-depth", type=int, default=None, metavar="N",
                   help="the longest path length (segments) of --strategy-images (default 5, "
                        "or the max depth if smaller)")
    g.add_argument("--stats", default=None, metavar="FILE.json",
                   help="write statistics: device, scene hash, seed, spp, times, samples/s, "
                        "non-finite samples, mean relative standard error")
    g = p.add_argument_group("checkpoints")
    g.add_argument("--checkpoint", default=None, metavar="FILE",
                   help="checkpoint file (default: OUT.ckpt); written at exit when given")
    g.add_argument("--checkpoint-every", type=float, default=None, metavar="SECONDS",
                   help="write a checkpoint every SECONDS of rendering and at exit")
    g.add_argument("--resume", action="store_true",
                   help="continue from the checkpoint (bitwise the same final image)")
    g.add_argument("--overwrite", action="store_true",
                   help="start afresh even though the checkpoint is there, replacing it "
                        "(without --resume or --overwrite a render refuses to start)")
    g = p.add_argument_group("cluster (pip install 'glrender[distributed]'; docs/scale-out.md)")
    g.add_argument("--workers", type=int, default=None, metavar="N",
                   help="render on a local Dask cluster of N worker processes")
    g.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="render on the Dask cluster of this scheduler (tcp://HOST:PORT, tls://...)")
    g.add_argument("--frames", default=None, metavar="A:B",
                   help="render frames A through B of an animated scene (':' all of its range) "
                        "to -o with a {frame} pattern, e.g. -o 'out/f{frame:04d}.exr'")
    g.add_argument("--unit-size", type=int, default=None, metavar="N",
                   help="pixel-samples per work unit (default: ~2 s of work, calibrated once "
                        "per device and integrator and cached; any size gives the same image)")
    g.add_argument("--scene-on-workers", default=None, metavar="PATH",
                   help="workers load the scene from PATH (a shared file system) instead of "
                        "receiving its files from this process")
    g.add_argument("--tls-ca", default=None, metavar="FILE", help="TLS: the cluster's CA certificate")
    g.add_argument("--tls-cert", default=None, metavar="FILE", help="TLS: this client's certificate")
    g.add_argument("--tls-key", default=None, metavar="FILE", help="TLS: this client's private key")
    g = p.add_argument_group("device and messages")
    _add_device(g)
    g.add_argument("--quiet", action="store_true", help="print nothing but errors")
    g.add_argument("--debug", action="store_true", help="show the traceback of errors")
    p.set_defaults(func=cmd_render)


def build_parser() -> argparse.ArgumentParser:
    from .. import __version__

    parser = _Parser(
        prog="glrender",
        description="A physically based renderer whose Monte Carlo core runs as GLSL compute "
                    "shaders (Mesa llvmpipe or a GPU, through EGL).",
        epilog="`glrender COMMAND --help` describes each command's options.")
    parser.add_argument("--version", action="version", version=f"glrender {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    sub.required = True

    _add_render(sub)

    p = sub.add_parser("info", help="list EGL devices, the chosen one and its limits",
                       description="List the EGL devices, the chosen device, GL_RENDERER, "
                                   "version, the limits the renderer relies on, llvmpipe's "
                                   "thread count and the shader cache location.")
    _add_device(p)
    p.add_argument("--json", action="store_true", help="print the report as JSON")
    p.set_defaults(func=cmd_info)

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

    from .lab import add_lab_parsers   # glrender lab, glrender compare (glrender/lab/)
    add_lab_parsers(sub, cmd_lab, cmd_compare)

    from .preview import add_preview_parser   # glrender preview (glrender/preview/)
    add_preview_parser(sub)
    from .options import add_search_path      # every command that loads a scene file
    add_search_path(sub.choices["preview"])
    return parser


def _show_warning(message, category, filename, lineno, file=None, line=None):
    print(f"glrender: warning: {message}", file=sys.stderr)


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    debug = getattr(args, "debug", False)
    if getattr(args, "quiet", False):
        warnings.simplefilter("ignore")
    elif not debug:
        warnings.showwarning = _show_warning
    signals = args.signals = StopSignals().install()
    try:
        from ..scene.loaders.scene_files import search_path
        from .compile_notice import compile_notice
        from .options import search_folders

        with search_path(search_folders(getattr(args, "search_path", None))), \
                compile_notice(enabled=not getattr(args, "quiet", False)):
            return int(args.func(args) or 0)
    except GlrenderError as exc:
        if debug:
            import traceback

            traceback.print_exc()
        message = str(exc) if debug else (str(exc).splitlines() or [type(exc).__name__])[0]
        print(f"glrender: error: {message}", file=sys.stderr)
        return exc.exit_code
    except MemoryError:
        if debug:
            import traceback

            traceback.print_exc()
        print("glrender: error: out of memory: render fewer pixels (--width/--height) or "
              "without --aov", file=sys.stderr)
        return 2
    except KeyboardInterrupt as exc:
        signum = getattr(exc, "signum", signal.SIGINT)
        print(f"glrender: interrupted ({signal.Signals(signum).name})", file=sys.stderr)
        return 128 + signum
    except BrokenPipeError:  # output piped into `head` and the like
        import os
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0
    except OSError as exc:   # a file the system would not let us read or write
        if debug:
            import traceback

            traceback.print_exc()
        where = f"{exc.filename}: " if exc.filename is not None else ""
        print(f"glrender: error: {where}{exc.strerror or exc}", file=sys.stderr)
        return 2
    finally:
        signals.uninstall()


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
