"""Which recorded curves share a panel: one panel per curve, except that a stage programme's curves of one quantity
recorded against one running abscissa are drawn as one curve in one panel, its stages placed end to end. A 21-stage
undrained shear with rate steps is then three panels (q, p', u against the axial strain since the start of shear),
not 63 short ones, and the rate steps show as the kinks they are; a consolidation's loading and unloading stages make
one compression curve.

``axes`` {(test, stage name): {abscissa: (axis, offset)}} (:func:`stage_axes`, from the study's tests through
:func:`cases.study.stages.sequence.record_axes`) says where each stage's records lie on its test's axes; a curve
without an entry (a flat test, a time since the stage start) has its own panel."""
from __future__ import annotations

from dataclasses import dataclass

from cases.study.outputs.figures.labels import panel_title
from cases.study.programme import split_key
from cases.study.stages.sequence import record_axes

__all__ = ["Panel", "stage_axes", "curve_panels"]


@dataclass(frozen=True)
class Panel:
    """The curves of ``test`` drawn in one panel: ``members`` ((curve key, x offset), ...) in stage order; a curve's
    abscissa plus its offset (the records' units) is the panel's abscissa."""

    test: str
    members: tuple

    @property
    def keys(self) -> tuple:
        return tuple(key for key, _ in self.members)

    def coverage(self, bands) -> float:
        """The share of the used records of the panel's curves inside their 95 % bands (``bands`` {(test, curve):
        inference.diagnosis PredictiveBand}), pooled over the curves."""
        mine = [bands[self.test, key] for key in self.keys]
        if len(mine) == 1:
            return mine[0].coverage
        used = sum(b.n_used for b in mine)
        if used == 0:   # no record used (all below the floor): NaN, as for one such curve
            return float("nan")
        return 1.0 - sum(int(b.outside.sum()) for b in mine) / used

    @property
    def label(self) -> str:
        """The panel's curves in words: the test and the curve (``T1 q@shear``), or the test, the quantity and the
        first and last stages of curves drawn end to end."""
        if len(self.members) == 1:
            return f"{self.test} {self.keys[0]}"
        (quantity, first), last = split_key(self.keys[0]), split_key(self.keys[-1])[1]
        return f"{self.test} {quantity} (stages {first} to {last})"

    @property
    def title(self) -> str:
        """The test, and the stage (or the first and last stages) the panel draws."""
        if len(self.members) == 1:
            return panel_title(self.test, self.keys[0])
        stages = [split_key(key)[1] for key in self.keys]
        return f"{self.test}, stages {stages[0]} to {stages[-1]} ({len(stages)})"


def stage_axes(tests) -> dict:
    """{(test name, stage name): {abscissa: (axis, offset)}} of every stage of the study's staged ``tests``
    (``cases.study.programme.TestSpec``) with more than one stage (the others' curves carry no stage)."""
    return {(t.name, s.name): axes for t in tests if t.staged and len(t.stages) > 1
            for s, axes in zip(t.stages, record_axes(t))}


def curve_panels(observations, axes: dict | None = None) -> list:
    """The panels of the recorded curves of ``observations`` (``inference.Observations``), in the order of their
    first curve: the curves of one test and quantity whose stages lie on one axis (``axes``, :func:`stage_axes`) share
    a panel; every other curve has its own. ``axes`` None: one panel per curve."""
    axes = axes or {}
    panels, shared = [], {}
    for t in observations:
        for key, curve in t.curves.items():
            quantity, stage = split_key(key)
            place = axes.get((t.name, stage), {}).get(curve.x_name)
            if place is None:
                panels.append((t.name, [(key, 0.0)]))
                continue
            axis, offset = place
            group = (t.name, quantity, axis)
            if group not in shared:
                shared[group] = []
                panels.append((t.name, shared[group]))
            shared[group].append((key, offset))
    return [Panel(test, tuple(members)) for test, members in panels]
