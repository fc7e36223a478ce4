"""Navigation metrics (habitat-lab definitions) on hand-computed trajectories."""

import math

import numpy as np
import pytest

from sdovon_mj import metrics as M

VP = np.array([[1.0, -1.2, 0.0]])
START = np.array([-3.0, 2.0, 0.0])


def test_straight_path_with_stop_is_perfect():
    path = np.linspace(START, VP[0], 11)
    m = M.episode_metrics(path, VP, stop_called=True)
    assert m.success == 1.0 and m.spl == pytest.approx(1.0) and m.soft_spl == pytest.approx(1.0)
    assert m.shortest == pytest.approx(math.hypot(4.0, 3.2))


def test_no_stop_fails_but_soft_spl_counts():
    path = np.linspace(START, VP[0], 5)
    m = M.episode_metrics(path, VP, stop_called=False)
    assert m.success == 0.0 and m.spl == 0.0 and m.soft_spl == pytest.approx(1.0)


def test_success_radius_is_strict_and_spl_penalises_detour():
    l = float(np.linalg.norm(START - VP[0]))
    end_in = VP[0] + np.array([0.09, 0, 0])
    end_out = VP[0] + np.array([0.11, 0, 0])
    assert M.episode_metrics([START, end_in], VP, True).success == 1.0
    assert M.episode_metrics([START, end_out], VP, True).success == 0.0
    assert M.success(True, 0.1, 0.1) == 0.0
    detour = [START, START + np.array([0, 5.0, 0]), VP[0]]
    p = 5.0 + float(np.linalg.norm(START + np.array([0, 5.0, 0]) - VP[0]))
    m = M.episode_metrics(detour, VP, True)
    assert m.spl == pytest.approx(l / p) and m.soft_spl == pytest.approx(l / p)
    half = [START, (START + VP[0]) / 2]
    assert M.episode_metrics(half, VP, True).soft_spl == pytest.approx(0.5)


def test_degenerate_shortest():
    assert M.spl(1.0, 0.0, 0.0) == 1.0 and M.soft_spl(0.0, 0.0, 1.0) == 1.0
    assert M.spl(1.0, math.inf, 3.0) == 0.0 and M.soft_spl(1.0, math.inf, 3.0) == 0.0
    agg = M.aggregate([M.EpisodeMetrics(1, 1, 1, 0, 1, 1), M.EpisodeMetrics(0, 0, 0.5, 2, 4, 2)])
    assert agg == {"episodes": 2, "success": 0.5, "spl": 0.5, "soft_spl": 0.75, "distance_to_goal": 1.0}
