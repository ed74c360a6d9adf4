"""How a workspace map samples (the sampler of a file, a resume must match it):
a frozen settings object built and checked once from the request
(:func:`SamplerSettings.make`), from which the sampler is built
(:func:`~elastica_petsc.studies.workspace.driver.make_sampler`) and the
file's root attributes are written (:meth:`SamplerSettings.attrs`)."""
from __future__ import annotations

from dataclasses import dataclass

from ...core.errors import InputError
from ...io.workspace import SAMPLERS


@dataclass(frozen=True)
class SamplerSettings:
    """The sampler of a map: mode ``targets`` (tip control, with the global search
    or local verdicts only) or ``tensions`` (forward solves); the tension
    sharing rule ``share`` and the floor P_min (``min_tension_N`` in N,
    ``min_tension`` = P_min l^2/B), docs/model.md §9.3."""

    mode: str
    global_search: bool = True
    share: str = "none"
    min_tension_N: float = 0.0
    min_tension: float = 0.0
    fill: bool = False             # mode targets: filled from the traced boundary first

    @classmethod
    def make(cls, arm, mode: str, global_search: bool = True, share: str | None = None,
             min_tension_N: float = 0.0, sampler: str | None = None) -> "SamplerSettings":
        """The settings of a request; :class:`InputError` for a bad one (a sharing
        rule or a floor in mode tensions, a floor not below the motor limit, an
        unknown ``sampler``).  ``sampler`` (mode targets): "boundary-fill" (the
        default with ``global_search``), "global-search" or "local" (the default
        without it); it overrides ``global_search``."""
        from ...solvers.share import share_rule

        names = SAMPLERS["targets"]
        if sampler is not None and sampler not in names:
            raise InputError(f"sampler {sampler!r}: expected one of {', '.join(names)}")
        if sampler is not None and mode != "targets":
            raise InputError("a sampler applies to mode targets only (mode tensions: forward "
                             "solves)")
        if sampler is None:
            sampler = "boundary-fill" if global_search else "local"
        rule = share_rule(share, float(min_tension_N))
        if mode != "targets" and rule != "none":
            raise InputError("--share/--min-tension-N apply to mode targets (tip control); "
                             "mode tensions prescribes the tensions")
        p_min = float(arm.tensions_from_N(min_tension_N))
        if arm.max_tension is not None and p_min >= arm.max_tension:
            raise InputError(f"--min-tension-N {min_tension_N:g} is not below the motor limit "
                             f"{arm.motor.max_tension_N:g} N")
        return cls(mode, sampler != "local", rule, float(min_tension_N), p_min,
                   mode == "targets" and sampler == "boundary-fill")

    @property
    def name(self) -> str:
        """The file's ``sampler`` attribute (:data:`~elastica_petsc.io.workspace.SAMPLERS`)."""
        if self.fill:
            return "boundary-fill"
        return SAMPLERS[self.mode][0 if self.global_search else -1]

    def attrs(self) -> dict:
        """The root attributes of a map file that these settings define."""
        return {"sampler": self.name, "share": self.share, "min_tension_N": self.min_tension_N,
                "min_tension": self.min_tension}
