"""The ``biped`` command: a thin layer that parses arguments and calls the library.

Each subcommand lives in its own module ``biped.cli.<name>`` exposing ``register(subparsers)``,
which adds its parser and sets ``func(args) -> int``.

Exit status of every command (see docs/cli.md):
    0    the command ran to its end and wrote its outputs (whatever the physics did: a fall is a
         result, reported in the summary);
    1    the run failed for a reason outside its inputs: out of memory, a file that could not be
         written (disk full, permissions changed meanwhile);
    2    bad input, refused before any work: a one-line ``biped COMMAND: error: ...`` naming the
         parameter and what is valid (argparse's own errors use the same prefix and status);
    130  interrupted (Ctrl-C / SIGINT): outputs of what had been computed are written if the
         command can (``biped push``, ``biped sweep``), then it stops;
    143  terminated (SIGTERM): as 130.
"""

from __future__ import annotations

import argparse
import importlib
import re
import signal
import sys
import threading

from biped.errors import BipedError

SUBCOMMANDS = ("push", "posture", "walk", "sweep", "envelope", "model", "validate")

#: Options naming a file or folder: an empty value is refused (it would read as "not given").
_PATH_OPTIONS = ("out", "model", "scenario", "grid", "plot", "animation", "video")

EXIT_OK, EXIT_FAILED, EXIT_BAD_INPUT, EXIT_INTERRUPTED, EXIT_TERMINATED = 0, 1, 2, 130, 143

#: Negative numbers as values, e.g. ``--block-velocity -1e6 0 0`` (argparse's own pattern misses
#: exponents, infinities and NaN, so such values were read as unknown options).
_NEGATIVE_NUMBER = re.compile(r"^-(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?$|^-(inf|infinity|nan)$", re.IGNORECASE)


class Parser(argparse.ArgumentParser):
    """argparse with negative numbers in any float syntax read as values, and the full name of the
    (sub)command that parsed the line kept in ``args._prog`` for error messages."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self._negative_number_matcher = _NEGATIVE_NUMBER

    def parse_known_args(self, args=None, namespace=None):
        namespace, rest = super().parse_known_args(args, namespace)
        if not hasattr(namespace, "_prog"):  # the innermost subcommand sets it first
            namespace._prog = self.prog
            namespace._parser = self
        return namespace, rest


def build_parser(command: str | None = None) -> argparse.ArgumentParser:
    """The parser of every subcommand, or of ``command`` alone (a name of :data:`SUBCOMMANDS`:
    a command line naming it parses the same, without importing the others' modules, e.g.
    ``biped posture``'s scipy)."""
    from biped import __version__

    parser = Parser(
        prog="biped",
        description="Balance of human-like bipeds: Wendlandt's workspace controller, Bediz's models.",
    )
    parser.add_argument("--version", action="version", version=f"biped {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name in SUBCOMMANDS if command not in SUBCOMMANDS else (command,):
        try:
            module = importlib.import_module(f"biped.cli.{name}")
        except ModuleNotFoundError as exc:  # a subcommand not built yet
            if exc.name != f"biped.cli.{name}":
                raise
            continue
        module.register(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Run one command; returns its exit status (module docstring). argparse's errors exit 2."""
    from biped.cli._common import finish_runs

    words = list(sys.argv[1:] if argv is None else argv)
    parser = build_parser(words[0] if words else None)
    args, rest = parser.parse_known_args(argv)
    bare = next((w for w in words if w.startswith("-") and w.endswith("=--")), None)
    if bare is not None:  # argparse hands '--opt=--' on as an empty list, not as the text '--'
        sub = getattr(args, "_parser", parser)
        sub.error(
            f"{bare.split('=', 1)[0]} needs a value; got '--' (which argparse reads as the end of options)"
        )
    if rest:  # said by the subcommand that got them, with its usage line
        sub = getattr(args, "_parser", parser)
        sub.error(f"unrecognized arguments: {' '.join(rest)}{_extra_values(sub, argv, rest)}")
    if not getattr(args, "func", None):
        parser.print_help()
        return EXIT_BAD_INPUT
    sub = getattr(args, "_parser", parser)
    # an option that may be given bare (nargs="?", const "": `biped sweep --plot` beside the
    # results) reads "" when given so; that is not an empty path
    bare_ok = {a.dest for a in sub._actions if a.nargs == "?" and a.const == ""}
    empty = next((k for k in _PATH_OPTIONS if k not in bare_ok and getattr(args, k, None) == ""), None)
    if empty is not None:  # '' would otherwise silently mean the default
        sub.error(
            f"--{empty.replace('_', '-')} '' is an empty path; name a file or folder, or leave the option out"
        )
    prog = getattr(args, "_prog", None) or f"biped {args.command}"
    try:
        code, ok = _run(args, prog)
    except BaseException:  # not a status (a bug): close the folders, then let it show
        finish_runs(False)
        raise
    try:
        finish_runs(ok, prog.removeprefix("biped "))
    except OSError as exc:  # the run marker could not be written (disk full...)
        print(f"{prog}: error: {_file_error(exc)}", file=sys.stderr)
        return EXIT_FAILED
    return code


def _file_error(exc: OSError) -> str:
    where = f" {exc.filename!r}" if getattr(exc, "filename", None) else ""
    return f"file system:{where} {exc.strerror or exc}"


def _run(args, prog: str) -> tuple[int, bool]:
    """(exit status, whether the run's folders get their run marker) of the command."""
    terminated = {"by": False}
    previous = _sigterm_as_interrupt(terminated)
    try:
        code = int(args.func(args) or 0)
        if code == EXIT_INTERRUPTED and terminated["by"]:
            code = EXIT_TERMINATED
        return code, code in (EXIT_OK, EXIT_INTERRUPTED, EXIT_TERMINATED)
    except BipedError as exc:
        print(f"{prog}: error: {_one_line(exc)}", file=sys.stderr)
        return EXIT_BAD_INPUT, False
    except KeyboardInterrupt:
        print(f"{prog}: {'terminated (SIGTERM)' if terminated['by'] else 'interrupted'}", file=sys.stderr)
        return (EXIT_TERMINATED if terminated["by"] else EXIT_INTERRUPTED), False
    except MemoryError:
        print(
            f"{prog}: error: out of memory; use a smaller problem (see --help for the bounds)",
            file=sys.stderr,
        )
        return EXIT_FAILED, False
    except OSError as exc:
        print(f"{prog}: error: {' '.join(_file_error(exc).split())}", file=sys.stderr)
        return EXIT_FAILED, False
    finally:
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)


def _sigterm_as_interrupt(state: dict):
    """SIGTERM raises KeyboardInterrupt (and sets ``state["by"]``), so a terminated command ends
    as an interrupted one: what was computed is written, then exit 143. Returns the previous
    handler (None outside the main thread, where signals cannot be handled)."""
    if threading.current_thread() is not threading.main_thread():
        return None

    def handler(signum, frame):
        state["by"] = True
        raise KeyboardInterrupt

    return signal.signal(signal.SIGTERM, handler)


def _extra_values(parser: argparse.ArgumentParser, argv: list[str] | None, rest: list[str]) -> str:
    """`` (--opt takes N values)`` when the first unrecognized word is a value left over after an
    option of fixed arity (``--block-position 0 0 0 0``), else ''."""
    argv = list(sys.argv[1:] if argv is None else argv)
    if "--" in rest and "--" in argv:  # argparse's end of options: what follows is left over
        before = [w for w in argv[: argv.index("--")] if w.startswith("-") and not _NEGATIVE_NUMBER.match(w)]
        after = f" after {before[-1].split('=', 1)[0]}" if before else ""
        return f" (the bare '--'{after} ends the options, so the words after it are left over; drop it)"
    first = rest[0]
    if first.startswith("-") and not _NEGATIVE_NUMBER.match(first):
        return ""
    for i in range(len(argv) - 1, -1, -1):  # the last occurrence: the leftover value
        if argv[i] == first:
            break
    else:
        return ""
    for word in reversed(argv[:i]):
        if word.startswith("-") and not _NEGATIVE_NUMBER.match(word):
            action = parser._option_string_actions.get(word.split("=", 1)[0])
            n = 1 if action is not None and action.nargs is None else getattr(action, "nargs", None)
            if isinstance(n, int):
                return f" ({word} takes {n or 'no'} value{'s' if n != 1 else ''})"
            return ""
    return ""


def _one_line(exc: BaseException) -> str:
    return " ".join(str(exc).split())


if __name__ == "__main__":
    sys.exit(main())
