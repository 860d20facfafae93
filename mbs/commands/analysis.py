"""info, equilibrium, linearize: what a model is and where it rests."""

from __future__ import annotations

from .common import check_scene, model_args, param_arg, params_from_args
from .hook_args import hook_arg, hooks_from_args
from .model_files import summary


class Info:
    help = "topology, coordinates and degrees of freedom of a model"

    @staticmethod
    def arguments(p):
        model_args(p)
        p.add_argument("--assemble", action="store_true",
                       help="close the loops at the start (compiles the model): rank, degrees of freedom, "
                            "redundant constraints, what assembly changed")
        p.add_argument("--scene", help="with --assemble: the scene whose start to assemble")
        hook_arg(p)

    @staticmethod
    def run(args) -> int:
        import mbs
        from mbs.compiler.topology import build_topology
        from mbs.language import units as U
        system = mbs.load(args.file, args.model)
        model = system.model
        topo = build_topology(model)
        print(summary(model))
        print("  spanning tree (parent first):")
        for i, (body, joint) in enumerate(zip(topo.bodies, topo.joints)):
            parent = "inertial" if topo.parent_index[i] < 0 else topo.bodies[topo.parent_index[i]]
            flipped = " (written child -> parent)" if joint.flipped else ""
            print(f"    {body:24s} <- {joint.interaction.joint.kind:11s} {joint.interaction.name} from {parent}{flipped}")
        for cut in topo.cuts:
            print(f"  loop closed by {cut.name} ({cut.joint.kind})")
        for state in model.states:  # extra differential states (language/states.py)
            unit = f" [{U.unit_text(state.dimension)}]" if state.dimension is not None else ""
            print(f"  state {state.name}{unit}" + (f"  {state.description}" if state.description else ""))
        if args.assemble and topo.cuts:
            _print_assembly(system.assemble(args.scene, hooks=hooks_from_args(args)), system.generate(args.scene))
        return 0


def _print_assembly(assembly, generated) -> None:
    """The mobility of the assembled start: rank and DOF from the constraint Jacobian, not from counting."""
    nc = generated.constraints.nc
    print(f"  assembled at the start: {nc} constraint rows of rank {assembly.rank}, "
          f"{assembly.dof} degree(s) of freedom, max |g| = {assembly.residual:.2g}")
    if assembly.idle:
        print(f"  idle: {len(assembly.idle)} row(s) hold by the geometry alone (no motion can violate them): "
              f"{', '.join(assembly.idle)}")
    if assembly.redundant:
        joints = sorted({name.rsplit(".", 1)[0] for name in assembly.redundant})
        n = nc - len(assembly.idle) - assembly.rank
        print(f"  redundant: {n} row(s) depend on others, among {', '.join(assembly.redundant)} (joints "
              f"{', '.join(joints)}): overconstrained but mobile; the solver drops the dependent rows, whose "
              "reactions rigid-body mechanics cannot determine")
    for name, given, after in assembly.changed:
        print(f"  assembly moved {name}: {given:.6g} -> {after:.6g}")


class Equilibrium:
    help = "find the static equilibrium of a model (it settles on its springs) and report it"

    @staticmethod
    def arguments(p):
        model_args(p)
        p.add_argument("--scene", help="scene whose parameters and outputs to use")
        param_arg(p)
        hook_arg(p)

    @staticmethod
    def run(args) -> int:
        import mbs
        system = mbs.load(args.file, args.model)
        check_scene(system, args.scene)
        params = params_from_args(args, system)
        hooks = hooks_from_args(args)
        result, outputs = system.equilibrium(args.scene, params=params, hooks=hooks)
        compiled = system.compile(args.scene, hooks=hooks)
        print(f"{system.model.name}: static equilibrium, max |acceleration| {result.residual:.3g} "
              f"({result.steps} relaxation steps, {result.resets} restarts)")
        units = compiled.units
        for name, value in zip(compiled.q_names, result.x[:compiled.nq]):
            print(f"  {name:32s} {value: .9g} {units.get(name, '')}")
        for name, value in zip(compiled.z_names, result.x[compiled.nq + compiled.nv:]):
            print(f"  {name:32s} {value: .9g} {units.get(name, '')}  (state)")
        for name, value in outputs.items():
            print(f"  {name:32s} {value: .9g} {units.get(name, '')}  (output)")
        return 0


class Linearize:
    help = "linearise a model about its static equilibrium: natural frequencies, damping ratios, mode shapes"

    @staticmethod
    def arguments(p):
        model_args(p)
        p.add_argument("--scene", help="scene whose parameters to use")
        param_arg(p)
        hook_arg(p)
        p.add_argument("--at", choices=("equilibrium", "initial"), default="equilibrium",
                       help="linearise about the static equilibrium (default) or the initial state")

    @staticmethod
    def run(args) -> int:
        import mbs
        system = mbs.load(args.file, args.model)
        check_scene(system, args.scene)
        params = params_from_args(args, system)
        lin = system.linearize(args.scene, params=params, at=args.at, hooks=hooks_from_args(args))
        head = f"{system.model.name}" + (f" / scene {args.scene}" if args.scene else "")
        print(f"{head}: linearised about the {'static equilibrium' if args.at == 'equilibrium' else 'initial state'}"
              f", {lin.dof} degree{'s' if lin.dof != 1 else ''} of freedom")
        print(lin.table())
        if lin.dof:
            print("undamped natural frequencies [Hz]: " + ", ".join(f"{f:.5g}" for f in lin.undamped_frequencies))
        if lin.state_space is not None and lin.state_space.inputs:
            print(lin.state_space.table())
        return 0
