"""The sampled region of a workspace map (issue 26): the paper's half-disc for
the paper's arm and for reproduce, the whole disc of reach for a user's arm
(half of an asymmetric arm's W_0 may lie below y = 0), and the map says which."""
from __future__ import annotations

import argparse

import numpy as np
import pytest

from elastica_petsc.cli.workspace import default_region
from elastica_petsc.core.errors import InputError
from elastica_petsc.studies.workspace.grids import target_grid


def test_disc_and_half_disc_lattices():
    half = target_grid(450.0, 150.0, region="half-disc")
    whole = target_grid(450.0, 150.0, region="disc")
    assert half.meta["region"] == "half-disc y >= 0, |x| <= l = 450 mm"
    assert whole.meta["region"] == "disc |x| <= l = 450 mm"
    assert half.points[:, 1].min() == 0.0 and whole.points[:, 1].min() == -450.0
    # the disc is the half-disc and its mirror image, the line y = 0 once
    upper = {tuple(p) for p in half.points}
    mirrored = {(x, -y) for x, y in upper}
    assert {tuple(p) for p in whole.points} == upper | mirrored
    assert np.all(np.hypot(*whole.points.T) <= 450.0 * (1 + 1e-12))
    with pytest.raises(InputError, match="region"):
        target_grid(450.0, 150.0, region="square")


@pytest.mark.parametrize("config, region, expected", [
    (None, None, "half-disc"),                 # the paper's arm: the paper's Fig. 4 region
    ("arm.toml", None, "disc"),                # a user's arm: the whole reach
    ("arm.toml", "half-disc", "half-disc"),
    (None, "disc", "disc"),
])
def test_default_region(config, region, expected):
    assert default_region(argparse.Namespace(config=config, region=region)) == expected
