"""The ``mbs`` command. Exit status: 0 success, 1 a model or run failed, 2 bad usage, 3 internal error.

Every command turns our own errors (MbsError) into located messages on stderr; anything else is a bug and
is reported as one, with the traceback only under --debug.
"""

from __future__ import annotations

import argparse
import sys
import traceback

from .commands import COMMANDS
from .commands.common import is_usage_error, render_error

EXIT_OK, EXIT_MODEL, EXIT_USAGE, EXIT_INTERNAL = 0, 1, 2, 3


def build_parser() -> argparse.ArgumentParser:
    from . import __version__
    parser = argparse.ArgumentParser(prog="mbs", description="Baukasten multibody compiler for vehicle dynamics.",
                                     epilog="exit status: 0 ok, 1 a model or run failed, 2 bad usage, "
                                            "3 internal error (a bug)")
    parser.add_argument("--version", action="version", version=f"mbs {__version__}")
    parser.add_argument("-v", "--verbose", dest="log_verbose", action="count", default=0,
                        help="say what happens (compile phases, build cache hit or miss, times); -vv for details")
    parser.add_argument("-q", "--quiet", dest="log_quiet", action="store_true",
                        help="errors only (no warnings, no notes of compile phases slower than a second)")
    parser.add_argument("--debug", action="store_true", help="show Python tracebacks of internal errors")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name, command in COMMANDS.items():
        p = sub.add_parser(name, help=command.help, description=command.help)
        command.arguments(p)
        p.set_defaults(run=command.run)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "run", None):
        parser.print_help(sys.stderr)
        return EXIT_USAGE
    restore = _configure_logging(args.log_verbose, args.log_quiet)
    from mbs.language.diagnostics import MbsError
    try:
        return args.run(args)
    except MbsError as err:
        print(render_error(err), file=sys.stderr)
        return EXIT_USAGE if is_usage_error(err) else EXIT_MODEL
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:
        return EXIT_OK
    except Exception as exc:  # noqa: BLE001 - the last line of defence against tracebacks
        if args.debug:
            traceback.print_exc()
        print(f"mbs: internal error: {type(exc).__name__}: {exc}\n(this is a bug in mbs; rerun with --debug "
              "for the traceback and report it)", file=sys.stderr)
        return EXIT_INTERNAL
    finally:
        restore()


def _configure_logging(verbose: int, quiet: bool):
    """The library logs through `logging` (logger 'mbs.*'); the command shows it on stderr. Returns the function
    that puts the logger back as it was (main() called from Python, e.g. by tests, leaves no trace)."""
    import logging
    note = 25  # mbs.pipeline.NOTE: compile phases slower than a second (not importing the pipeline here)
    level = logging.ERROR if quiet else (note, logging.INFO)[min(verbose, 1)] if verbose < 2 else logging.DEBUG
    handler = logging.StreamHandler(sys.stderr)
    handler.setFormatter(logging.Formatter("mbs: %(message)s"))
    logger = logging.getLogger("mbs")
    saved = (logger.handlers[:], logger.level, logger.propagate)
    logger.handlers[:] = [handler]
    logger.setLevel(level)
    logger.propagate = False

    def restore() -> None:
        logger.handlers[:], logger.level, logger.propagate = saved
    return restore


if __name__ == "__main__":
    sys.exit(main())
