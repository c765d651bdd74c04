"""Pieces shared by the command-line tools: argument checks, output folders, a study's files."""

from __future__ import annotations

import argparse
import json
from collections.abc import Callable
from pathlib import Path
from typing import Any


def out_dir(parser: argparse.ArgumentParser, value: str) -> Path:
    """Create the output folder or stop with a clear message."""
    path = Path(value)
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        parser.error(f"--out {value!r}: cannot create the folder ({exc.strerror})")
    return path


def write_study(out: Path, name: str, results: dict[str, Any],
                markdown: Callable[[dict[str, Any]], str],
                draw: Callable[[dict[str, Any], Path], None]) -> None:  # fmt: skip
    """A study's results as ``<name>.json``, its tables as ``<name>.md`` (printed too) and its
    figure as ``<name>.png`` in ``out``."""
    (out / f"{name}.json").write_text(json.dumps(results, indent=2))
    md = markdown(results)
    (out / f"{name}.md").write_text(md)
    draw(results, out / f"{name}.png")
    print(md)
    print(f"wrote {out / f'{name}.json'}, {out / f'{name}.md'}, {out / f'{name}.png'}")
