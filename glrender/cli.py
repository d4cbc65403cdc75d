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
