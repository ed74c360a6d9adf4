"""``elastica-petsc equilibria``: several equilibria for fixed tensions (load control,
paper Fig. 8: states 1 and 3 share p = (25.2, 10.8)).

The multi-start search of :func:`elastica_petsc.studies.search.equilibria`: loading paths from the
straight arm (proportional and every order), loading paths from a spread of
load-controlled starts, then deflated Newton solves.  Output layout as for
``elastica-petsc lengths`` (see :mod:`.lengths`); ``stable`` is the stability
under load control, and every state is also judged held at its own cable lengths.
"""
from __future__ import annotations

from . import common
from .lengths import add_search_options, add_vtk_option


def add_parser(sub) -> None:
    parser = sub.add_parser(
        "equilibria", help="several equilibria for given tensions (load control, Fig. 8)",
        description="Search for several equilibria of the arm at fixed cable tensions (load "
                    "control): loading paths from the straight arm in every order (both sides "
                    "of every bifurcation), a curve search (two tendons: load paths on lines "
                    "through the tensions followed through their folds, from the straight arm "
                    "and through every state found), deflated continuation in the tensions, "
                    "loading paths from a spread of load-controlled starts, and deflated Newton solves "
                    "(Fig. 8: states 1 and 3 share p = (25.2, 10.8)). Each state is reported "
                    "with tip, cable lengths and its stability under load control and, held "
                    "at its own cable lengths, under length control. What the search finds is "
                    "not proven to be everything.")
    common.add_tension_options(parser)
    add_search_options(parser)
    add_vtk_option(parser)
    common.add_arm_options(parser)
    common.add_output_options(parser)
    parser.set_defaults(run=run)


def run(args) -> int:
    from ..ui.progress import Progress
    from ..solvers.equilibrium import check_tensions
    from ..studies.search import search_tensions
    from ..io.summary import rounded
    from ..io.summaries import search_summary, state_summary
    from .lengths import NOT_COMPLETE, check_search_options, finish

    arm, disc = common.load_arm(args)
    p = check_tensions(common.tensions(args, arm), disc.n_tendons)
    settings = check_search_options(args)
    common.check_outputs(args)
    with Progress(None, "equilibria", unit="search steps") as bar:
        result = search_tensions(arm, p, elements=disc.n_elements, effort=args.effort,
                                 levels=args.levels, deflation_rounds=args.deflation_rounds,
                                 progress=bar, max_seconds=settings["max_seconds"])
    states = [f.state for f in result.states]
    data = {"control": "load", "tensions": rounded(p), "tensions_N": rounded(arm.tensions_to_N(p)),
            "elements": disc.n_elements,
            "equilibria": [state_summary(arm, f.state, "load", f) for f in result.states],
            "search": search_summary(result, settings), "note": NOT_COMPLETE}
    title = ("Equilibria found at p = (" + ", ".join(f"{v:g}" for v in p)
             + ") (load control)")
    return finish(args, arm, data, states, "load_equilibria", title)
