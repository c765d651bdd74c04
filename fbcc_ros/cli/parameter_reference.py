"""Writes docs/parameters.md, the parameter reference, from the nodes' tables (the one source).

    python -m fbcc_ros.cli.parameter_reference [OUT.md]

A test checks that the committed file is what this prints, so the reference cannot go stale.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from fbcc_ros.core.errors import command
from fbcc_ros.nodes import (
    dynamic_compensation,
    fbcc_controller,
    fbcc_record,
    kinematics,
    mock_cell,
)
from fbcc_ros.pipeline.parameters import Param

MODULES = (mock_cell, dynamic_compensation, kinematics, fbcc_controller, fbcc_record)


def _range(p: Param) -> str:
    if p.choices:
        return " \\| ".join(f"`{c}`" for c in p.choices)
    if p.low is not None and p.high is not None:
        if isinstance(p.default, int):
            return f"{int(p.low)} … {int(p.high)}"
        return f"{p.low:g} … {p.high:g}"
    return ""


def markdown() -> str:
    lines = [
        "# Parameter reference",
        "",
        "Generated from the nodes' parameter tables by "
        "`python -m fbcc_ros.cli.parameter_reference`;",
        "do not edit by hand. `config/<node>.yaml` holds every key with its default;",
        "`ros2 param describe` shows the same descriptions at runtime. *writable*: may be",
        "changed while the node runs (`ros2 param set`); the others are read-only.",
    ]
    for module in MODULES:
        name = module.__name__.rsplit(".", 1)[1]
        lines += [
            "",
            f"## `{name}`",
            "",
            "| parameter | default | unit | range | |",
            "|---|---|---|---|---|",
        ]
        for p in module.TABLE:
            writable = "writable — " if not p.read_only else ""
            default = str(p.default).lower() if isinstance(p.default, bool) else p.default
            text = f"{writable}{p.description}"
            lines.append(f"| `{p.name}` | `{default}` | {p.unit} | {_range(p)} | {text} |")
    return "\n".join(lines) + "\n"


@command("parameter_reference")
def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m fbcc_ros.cli.parameter_reference",
                                     description=__doc__.splitlines()[0])  # fmt: skip
    parser.add_argument("out", nargs="?", type=Path, default=Path("docs/parameters.md"),
                        help="the Markdown file to write (default: docs/parameters.md)")
    out = parser.parse_args(argv).out
    out.write_text(markdown())
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
