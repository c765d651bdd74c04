"""The command line every study that draws insertions shares: ``--trials`` and ``--seed``,
checked, with the study's own options added by the caller."""

from __future__ import annotations

import argparse


def insertion_study_parser(module: str, doc: str, trials: int) -> argparse.ArgumentParser:
    """``python -m fbcc_ros.studies.MODULE`` with ``--trials`` (default ``trials``) and
    ``--seed``; :func:`parse` checks them."""
    parser = argparse.ArgumentParser(prog=f"python -m fbcc_ros.studies.{module}",
                                     description=doc.splitlines()[0])  # fmt: skip
    parser.add_argument("--trials", type=int, default=trials,
                        help=f"insertions per plant ({trials})")  # fmt: skip
    parser.add_argument("--seed", type=int, default=0, help="of the parts and deviations (0)")
    return parser


def parse(parser: argparse.ArgumentParser, argv: list[str] | None) -> argparse.Namespace:
    """The arguments, ``--trials`` >= 1 and ``--seed`` >= 0 (else exit 2 naming the value)."""
    args = parser.parse_args(argv)
    if args.trials < 1:
        parser.error(f"--trials {args.trials}: expected an integer >= 1")
    if args.seed < 0:
        parser.error(f"--seed {args.seed}: expected an integer >= 0")
    return args
