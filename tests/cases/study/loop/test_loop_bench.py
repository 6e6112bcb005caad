"""The loop benchmark's phases read from loop.json (cases.study.loop.bench.phases): every second the loop records is
attributed once, and a convention tried but not adopted counts beside the classes."""
from cases.study.loop.bench import phases


def test_phases_sum_the_recorded_times():
    loop = {"phases_s": {"base": {"sampler": 10.0, "evidence": 4.0, "record_and_outputs": 1.0},
                         "base + viscosity": {"sampler": 20.0, "evidence": 8.0, "record_and_outputs": 1.5}},
            "conventions": [{"class": "base", "wall_s": 15.0}, {"class": "base (1 + e0)", "wall_s": 12.0}],
            "timing": {"screen_and_rank_s": 0.3, "diagnose_final_s": 0.2, "loop_s": 60.0},
            "steps_timing": [{"screen_and_rank_s": 0.1, "diagnose_final_s": 0.0}]}
    p = phases(loop)
    assert p["base: sampler"] == 10.0 and p["base + viscosity: record and outputs"] == 1.5
    assert p["conventions not adopted"] == 12.0
    assert abs(p["screening and diagnosis"] - 0.6) < 1e-12 and p["loop"] == 60.0
