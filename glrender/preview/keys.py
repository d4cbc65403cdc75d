"""The preview's key and mouse bindings: one table for the event handler, ``--help``,
the ``H`` key and the README."""
from __future__ import annotations

# (glfw key names, action, what it does); actions are PreviewApp.action_<name>(shift),
# None marks keys read while held (flying)
KEYS = (
    (("W", "A", "S", "D"), None, "fly forward / left / back / right while held (Shift: 4x)"),
    (("Q", "E"), None, "fly down / up while held"),
    (("R",), "reset_camera", "back to the scene's camera"),
    (("I",), "next_integrator", "integrator: path, direct, ao, lighttrace, bdpt, sppm, photon, vcm (Shift: back)"),
    (("M",), "next_strategy", "direct lighting: light, bsdf, mis-balance, mis-power (Shift: back)"),
    (("LEFT_BRACKET",), "depth_down", "max depth - 1 (from unbounded: 16)"),
    (("RIGHT_BRACKET",), "depth_up", "max depth + 1 (after 16: unbounded)"),
    (("V",), "next_view", "view: color, albedo, normal, variance (Shift: back)"),
    (("1", "2", "3", "4"), "view", "view color / albedo / normal / variance"),
    (("T",), "next_curve", "tone curve: clamp, filmic, aces"),
    (("MINUS", "KP_SUBTRACT"), "exposure_down", "exposure - 0.5 stop"),
    (("EQUAL", "KP_ADD"), "exposure_up", "exposure + 0.5 stop"),
    (("0",), "exposure_reset", "exposure 0"),
    (("N",), "denoise", "denoised color view on / off (Open Image Denoise, in the background)"),
    (("SPACE",), "pause", "pause / resume adding samples"),
    (("P", "F12"), "screenshot", "screenshot: PNG (the view), EXR (the accumulation), JSON"),
    (("H",), "help", "print the keys"),
    (("ESCAPE",), "quit", "quit (as closing the window)"),
)

MOUSE = (
    ("left drag", "orbit about the target"),
    ("right drag", "pan (also middle drag, Shift + left drag)"),
    ("wheel", "zoom toward / away from the target"),
)

_SHOWN = {"LEFT_BRACKET": "[", "RIGHT_BRACKET": "]", "MINUS": "-", "EQUAL": "=", "KP_SUBTRACT":
          "keypad -", "KP_ADD": "keypad +", "SPACE": "Space", "ESCAPE": "Esc"}


def key_label(names) -> str:
    return " ".join(_SHOWN.get(n, n) for n in names)


def help_text(indent: str = "  ") -> str:
    """The bindings as aligned lines (for --help and the H key)."""
    rows = [(key_label(names), text) for names, _, text in KEYS] + list(MOUSE)
    width = max(len(k) for k, _ in rows)
    return "\n".join(f"{indent}{k:<{width}}  {t}" for k, t in rows)


def bindings(glfw) -> dict[int, tuple[str, int]]:
    """glfw key code -> (action, index of the key in its group) for the pressed-key actions."""
    table = {}
    for names, action, _ in KEYS:
        if action is None:
            continue
        for i, name in enumerate(names):
            table[getattr(glfw, f"KEY_{name}")] = (action, i)
    return table
