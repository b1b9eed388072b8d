"""Small helpers shared by the writers: number formatting, process-parameter text, names."""

from __future__ import annotations

import re
import string

import numpy as np

from ..core.process import PARAMETERS_BY_NAME, ZONE_PARAMETERS

_IDENT = re.compile(r"^[A-Za-z][A-Za-z0-9_]*$")


def num(x: float, decimals: int = 3) -> str:
    """Fixed-point number without negative zero ("-0.000" → "0.000")."""
    s = f"{float(x):.{decimals}f}"
    return s[1:] if s.startswith("-") and float(s) == 0.0 else s


def short(x: float) -> str:
    """Compact number for comments (`%g`)."""
    return f"{float(x):g}"


def check_identifier(name: str, max_len: int, what: str = "program name") -> str:
    """A controller-safe identifier: letter first, then letters/digits/underscores, ≤ max_len."""
    if not _IDENT.match(name) or len(name) > max_len:
        raise ValueError(f"{what} {name!r} must start with a letter, use only letters, digits and "
                         f"'_' and have at most {max_len} characters")
    return name


def process_summary(params: dict) -> str:
    """'current 200 A, voltage 20 V, ...' in the table order of core/process.py (values present)."""
    parts = []
    for p in ZONE_PARAMETERS:
        if p.name in params:
            parts.append(f"{p.name} {short(params[p.name])}{(' ' + p.unit) if p.unit else ''}")
    extra = sorted(k for k in params if k not in PARAMETERS_BY_NAME)
    parts += [f"{k} {short(params[k])}" for k in extra]
    return ", ".join(parts)


def check_templates(templates: dict[str, str]) -> dict[str, str]:
    """Validate process-command templates: known parameter names, only the `{value}` field."""
    for name, tpl in templates.items():
        if name not in PARAMETERS_BY_NAME:
            raise ValueError(f"process template for unknown parameter {name!r} "
                             f"(known: {', '.join(PARAMETERS_BY_NAME)})")
        fields = [f for _, f, _, _ in string.Formatter().parse(tpl) if f is not None]
        if any(f != "value" for f in fields):
            raise ValueError(f"process template {tpl!r} for {name!r} may only use the field {{value}}")
        tpl.format(value=1.0)
    return dict(templates)


def process_lines(params: dict, templates: dict[str, str]) -> list[str]:
    """One command per parameter present in both `params` and `templates`, in table order."""
    return [templates[p.name].format(value=float(params[p.name]))
            for p in ZONE_PARAMETERS if p.name in params and p.name in templates]


def finite(x: float) -> bool:
    return bool(np.isfinite(x))
