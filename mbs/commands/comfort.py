"""comfort: ISO 2631-1 weighted RMS accelerations and tyre load fluctuations of a results file."""

from __future__ import annotations


def ride_report(res, skip: float = 1.0) -> list[tuple[str, float, str]]:
    """(what, value, unit) for every '*acc_x/y/z' output (Wd horizontally, Wk vertically) and every tyre load
    ('*.load'), from `skip` seconds on (the start transient left out), on the samples alone (not the rows that a
    scene with events adds at each event)."""
    from mbs.runtime import comfort
    keep = (res.t >= skip) & comfort.sample_rows(res.t)
    rows = []
    for name in res.names:
        if name.endswith(("acc_x", "acc_y", "acc_z")):
            weighting = "Wk" if name.endswith("_z") else "Wd"
            rows.append((f"{name} weighted RMS ({weighting})",
                         comfort.weighted_rms(res.t[keep], res[name][keep], weighting), "m/s^2"))
    for name in res.names:
        if name.endswith(".load"):
            rows.append((f"{name} RMS fluctuation / static", comfort.load_fluctuation(res[name][keep]), "-"))
    return rows


class Comfort:
    help = "ride comfort of a results file: ISO 2631-1 weighted RMS accelerations (outputs *acc_x/y/z) and tyre " \
           "load fluctuations (outputs *.load)"

    @staticmethod
    def arguments(p):
        p.add_argument("results", metavar="RESULTS", help="a results file of mbs simulate (.csv or .npz)")
        p.add_argument("--skip", type=float, default=1.0, help="leave out the first SKIP seconds (default 1)")

    @staticmethod
    def run(args) -> int:
        from mbs.runtime.results import Results
        res = Results.from_npz(args.results) if args.results.endswith(".npz") else Results.from_csv(args.results)
        rows = ride_report(res, args.skip)
        if not rows:
            print(f"{args.results}: no accelerations (*acc_x/y/z) or tyre loads (*.load) to assess")
            return 1
        for what, value, unit in rows:
            print(f"  {what:52s} {value:8.4g} {unit}")
        return 0
