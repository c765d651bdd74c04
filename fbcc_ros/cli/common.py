"""Pieces shared by the command-line tools: argument checks and output folders."""

from __future__ import annotations

import argparse
from pathlib import Path


def out_dir(parser: argparse.ArgumentParser, value: str) -> Path:
    """Create the output folder or stop with a clear message."""
    path = Path(value)
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        parser.error(f"--out {value!r}: cannot create the folder ({exc.strerror})")
    return path
