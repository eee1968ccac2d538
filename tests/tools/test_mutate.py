"""`make mutate` (mplang/tools/mutate.py): what makes a group's stored results stale."""

from __future__ import annotations

import copy

from mplang.tools import mutate


def test_editing_one_group_leaves_the_others_fingerprints_alone() -> None:
    """A group is rerun from scratch only when its own modules, tests or the common settings
    change: another group's entry in the groups table is none of these."""
    common, groups = mutate.load_groups()
    encoder = next(g for g in groups if g.name == "encoder")
    edited = copy.deepcopy(common)
    edited["groups"]["linker"]["tests"].append("tests/m8194h/test_encode.py")
    assert mutate.fingerprint(encoder, edited) == mutate.fingerprint(encoder, common)
    slower = {**common, "timeout_multiplier": common["timeout_multiplier"] + 1}
    first, second = (mutate.fingerprint(encoder, c).split("\n") for c in (common, slower))
    assert first[0] != second[0] and first[1] == second[1]
