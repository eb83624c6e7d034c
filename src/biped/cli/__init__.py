"""The ``biped`` command: a thin layer that parses arguments and calls the library.

Each subcommand lives in its own module ``biped.cli.<name>`` exposing ``register(subparsers)``,
which adds its parser and sets ``func(args) -> int``.
"""

from __future__ import annotations

import argparse
import importlib
import sys

from biped.errors import BipedError

SUBCOMMANDS = ("push", "posture", "walk", "sweep", "model")


def build_parser() -> argparse.ArgumentParser:
    from biped import __version__

    parser = argparse.ArgumentParser(
        prog="biped",
        description="Balance of human-like bipeds: Wendlandt's workspace controller, Bediz's models.",
    )
    parser.add_argument("--version", action="version", version=f"biped {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name in SUBCOMMANDS:
        try:
            module = importlib.import_module(f"biped.cli.{name}")
        except ModuleNotFoundError as exc:  # a subcommand not built yet
            if exc.name != f"biped.cli.{name}":
                raise
            continue
        module.register(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "func", None):
        parser.print_help()
        return 2
    try:
        return int(args.func(args) or 0)
    except BipedError as exc:
        print(f"biped {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"biped {args.command}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
