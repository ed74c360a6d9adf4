"""Several equilibria at one target (``lengths --out``, ``equilibria --out``).

HDF5 layout (``--out``), besides the provenance attributes of every file::

    target/lengths_mm        (n,)  mm        prescribed cable lengths   (lengths)
    target/tensions          (n,)  P l^2/B   prescribed tensions        (equilibria)
    target/tensions_N        (n,)  N
    equilibria/state_K/...   one group per state K (the paper's numbers for Fig. 8's
                             states, see studies.search.state_numbers): the layout of io.hdf5.write_equilibrium
                             plus tendons/lengths_requested (mm), tendons/slack (mm),
                             tendons/taut (1); solver attributes also hold
                             length_unstable_modes, stable_under_length_control,
                             found_start, found_method, hits
    root attributes          control, n_equilibria, state_numbers, search_* (method, starts,
                             attempts, failed, refound, start_labels_json, coverage_json,
                             effort_json), note
"""
from __future__ import annotations


from ..core import jsontext
from .hdf5 import atomic_h5, provenance, put, write_attrs, write_equilibrium


def write_states(path, overwrite: bool, arm, data: dict, states, kind: str) -> None:
    """The equilibria of ``lengths --out``/``equilibria --out`` (``data``: the
    command's JSON summary, ``states`` in its order; layout above)."""
    l_mm = arm.length_mm
    with atomic_h5(path, overwrite) as fh:
        write_attrs(fh, provenance(arm, kind))
        search = data["search"]
        write_attrs(fh, {"control": data["control"], "n_equilibria": len(states),
                         "elements": int(data["elements"]),
                         "search_method": search["method"], "search_starts": search["starts"],
                         "search_attempts": search["attempts"], "search_failed": search["failed"],
                         "search_refound": search["refound"],
                         "search_start_labels_json": jsontext.dumps(search["start_labels"]),
                         "search_coverage_json": jsontext.dumps(search.get("coverage", {})),
                         "search_effort_json": jsontext.dumps(search.get("effort", {})),
                         "search_complete": False, "note": data["note"],
                         "state_numbers": [int(s["number"]) for s in data["equilibria"]]})
        target = fh.create_group("target")
        if data["control"] == "length":
            put(target, "lengths_mm", data["lengths_mm"], "mm", "prescribed cable lengths L_i",
                ("tendon",))
        else:
            put(target, "tensions", data["tensions"], "P l^2/B", "prescribed tensions p_i",
                ("tendon",))
            put(target, "tensions_N", data["tensions_N"], "N", "prescribed tensions P_i",
                ("tendon",))
        group = fh.create_group("equilibria")
        for state, summary in zip(states, data["equilibria"]):
            g = group.create_group(f"state_{summary['number']}")
            write_equilibrium(g, arm, state)
            put(g["tendons"], "lengths_requested", state.lengths_requested * l_mm, "mm",
                "prescribed cable lengths L_i (load control: the state's own chords)", ("tendon",))
            put(g["tendons"], "slack", summary["slack_mm"], "mm",
                "L_i - |r_i - x_i| (> 0: slack cable, tension 0)", ("tendon",))
            put(g["tendons"], "taut", summary["taut"], "1", "cable carries tension", ("tendon",))
            solver = g["solver"]
            write_attrs(solver, {
                "length_unstable_modes": int(summary["unstable_modes_length_control"]),
                "stable_under_length_control": bool(summary["stable_under_length_control"]),
                "stable_under_load_control": bool(summary["stable_under_load_control"])})
            if "found_from" in summary:
                f = summary["found_from"]
                write_attrs(solver, {"found_start": f["start"], "found_method": f["method"],
                                     "hits": int(f["attempts_reaching_it"])})
