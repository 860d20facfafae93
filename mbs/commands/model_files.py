"""check, fmt, export: the commands that read model files without compiling them."""

from __future__ import annotations

import sys
from pathlib import Path

from .common import render_error


class Check:
    help = "parse and validate model files; report every error with its location"

    @staticmethod
    def arguments(p):
        p.add_argument("files", nargs="+", metavar="FILE")
        p.add_argument("-v", "--verbose", action="store_true", help="also print a summary of each model")
        p.add_argument("-W", "--no-warnings", action="store_true", help="hide warnings and notes")

    @staticmethod
    def run(args) -> int:
        from mbs.language.diagnostics import MbsError
        from mbs.language.frontend import check
        status = 0
        for path in args.files:
            try:
                result = check(path)
            except MbsError as err:
                print(render_error(err), file=sys.stderr)
                status = 1
                continue
            if not args.no_warnings:
                for d in result.diagnostics:
                    print(d.render(), file=sys.stderr)
            if args.verbose:
                for m in result.models:
                    print(summary(m))
            names = [m.name for m in result.models] + [f"{c} (component)" for c in result.components]
            print(f"{path}: ok ({', '.join(names) or 'no models'})")
        return status


def summary(model) -> str:
    from mbs.language.rules import degrees_of_freedom_estimate
    bodies = sum(1 for p in model.parts if p.body is not None)
    joints = sum(1 for i in model.interactions if i.joint is not None)
    coords = ", ".join(c.name + (" (prescribed)" if c.prescribed is not None else "") for c in model.coordinates)
    text = (f"model {model.name}: {len(model.parts)} parts ({bodies} rigid), {len(model.interactions)} interactions "
            f"({joints} joints), {len(model.parameters)} parameters, {degrees_of_freedom_estimate(model)} joint "
            f"velocities\n  coordinates: {coords or 'none'}\n  scenes: "
            f"{', '.join(s.name for s in model.scenes) or 'none'}")
    modes = [p.name for p in model.parameters if p.kind == "mode"]
    if modes or model.events:
        events = ", ".join(e.name + (" (terminal)" if e.terminal else "") for e in model.events)
        text += (f"\n  modes: {', '.join(modes) or 'none'}\n  events: {events or 'none'}"
                 f"\n  switches: {'on' if model.switches else 'off'} (comparisons and kinks as events)")
    return text


class Fmt:
    help = "print model files in canonical layout (or rewrite them with --in-place)"

    @staticmethod
    def arguments(p):
        p.add_argument("files", nargs="+", metavar="FILE")
        g = p.add_mutually_exclusive_group()
        g.add_argument("-i", "--in-place", action="store_true", help="rewrite the file (atomically)")
        g.add_argument("--check", action="store_true", help="exit 1 if the file is not formatted")

    @staticmethod
    def run(args) -> int:
        from mbs.base.atomic import write_text_atomic
        from mbs.language.formatter import format_source
        from mbs.language.parser import parse_source, read_source
        status = 0
        for path in args.files:
            source = read_source(path)
            text = format_source(parse_source(source), source)
            if args.check:
                if text != source.text:
                    print(f"{path}: not formatted", file=sys.stderr)
                    status = 1
            elif args.in_place:
                write_text_atomic(Path(path), text)
            else:
                sys.stdout.write(text)
        return status


class Export:
    help = "export the validated data model (method-independent, documented JSON schema)"

    @staticmethod
    def arguments(p):
        p.add_argument("file", metavar="FILE")
        p.add_argument("--json", action="store_true", help="JSON output (the only format and the default; "
                                                           "accepted for scripts that name it)")
        p.add_argument("--model", help="model name when the file has several")
        p.add_argument("-o", "--output", help="write to this file (atomically) instead of stdout")

    @staticmethod
    def run(args) -> int:
        from mbs.language.export import model_to_json
        from mbs.language.frontend import load
        text = model_to_json(load(args.file, args.model))
        if args.output:
            from mbs.base.atomic import write_text_atomic
            write_text_atomic(Path(args.output), text)
        else:
            sys.stdout.write(text)
        return 0
