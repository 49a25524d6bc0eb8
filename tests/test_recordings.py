"""Recordings of real robots as measurements (issue 35 item 4, docs/model.md
"Rows, repeats and copies", "The support test"): OpenCR's sysid files read
for `cdsm diagnose` by name or path, and the noise of data that sample
continuous motions estimated from neighbouring rows (no repeats needed).
SI units."""

from __future__ import annotations

import numpy as np
import pytest

import cdsm
from cdsm.calibration import diagnosis, plant
from cdsm.calibration.measurements import Measurements, commanded_cables, read_for
from cdsm.inputs import CdsmInputError
from cdsm.interop import opencr


@pytest.fixture(scope="module")
def v4():
    return cdsm.Robot.load("ftdcr_v4")


def test_a_recording_is_read_by_name_as_tendon_commands_from_rest(v4):
    m = read_for(v4, "ftdcr_v4_train")
    # the file's first data row, in mm: servos k0..k8 then the tip
    first = "-0.061359,-0.03068,-0.01534,-0.046019,-0.01534,-0.01534,0.0,0.0,-0.107379".split(",")
    assert m.reading == "absolute" and len(m) == 1620 and m.n == 60
    assert m.dL.shape == (1620, 9) and m.theta.shape == (1620, 60)
    # a pull of d m is the command dL = -d from the rest angles
    np.testing.assert_array_equal(m.dL[0], [-float(v) * 1e-3 for v in first])
    np.testing.assert_array_equal(m.theta, 0.0)
    np.testing.assert_allclose(m.measured[0], [-2.085078e-3, 8.168024e-3, 187.961009e-3], rtol=1e-15)
    assert m.labels["pattern_label"][20] == "rep1_tendon0_id4_pull_hold"
    assert m.labels["pattern"][20] == "rep1_tendon0_id4_pull"
    assert m.fold_groups == "pattern" and m.sampled
    assert commanded_cables(v4) == list(range(9))


def test_a_recording_is_recognised_by_its_columns_at_any_path(v4, tmp_path):
    text = open(opencr.packaged("ftdcr_v4_val"), encoding="utf-8").read()
    path = tmp_path / "my_session.csv"
    path.write_text(text, encoding="utf-8")
    a, b = read_for(v4, str(path)), read_for(v4, "ftdcr_v4_val")
    np.testing.assert_array_equal(a.dL, b.dL)
    np.testing.assert_array_equal(a.measured, b.measured)
    assert len(a) == 443


def test_a_recording_for_another_robot_is_refused_naming_both_counts():
    with pytest.raises(CdsmInputError, match=r"9 servo columns .* commands 4 cable"):
        read_for(cdsm.Robot.load("two_universal"), "ftdcr_v4_train")


def test_rows_out_of_time_order_are_refused_naming_the_row(v4, tmp_path):
    lines = open(opencr.packaged("ftdcr_v4_tendon_pull"), encoding="utf-8").read().splitlines()
    lines[5], lines[6] = lines[6], lines[5]
    path = tmp_path / "swapped.csv"
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    with pytest.raises(CdsmInputError, match=r"row 6, column 'timestamp'"):
        read_for(v4, str(path))


def test_robots_by_name_include_opencrs_configs(v4):
    assert v4.n == 60 and v4.displacement_cables == list(range(9))
    with pytest.raises(CdsmInputError, match="ftdcr_v4"):
        cdsm.Robot.load("ftdcr_v5")
    # the design: its sysid config without the fitted pretension (and with the design tendon angles)
    sysid = cdsm.Robot.load("ftdcr_v4_sysid")
    np.testing.assert_array_equal(v4.elastic_cables()["pretension"], 0.0)
    np.testing.assert_allclose(sysid.elastic_cables()["pretension"][[0, 3, 6]],
                               [0.0005778742714404039, 1.160521809308655, 3.8746889591736853], rtol=1e-15)


# ---------------------------------------------------------------------------
# the noise of sampled motions, from neighbouring rows
# ---------------------------------------------------------------------------
SIGMA = 20e-6


def _sampled(noise: float, seed: int = 3, trend=None, jumps: float = 0.0):
    """Five smooth motions of 60 rows of the two-universal arm, read in its
    base frame with Gaussian noise ``noise`` (m per axis) on the nominal
    tips, plus ``trend(i, pattern)`` (m, (3,)) if given."""
    robot = cdsm.Robot.load("two_universal")
    rng = np.random.default_rng(seed)
    s = np.linspace(0.0, 1.0, 60)
    theta, labels = [], []
    for p in range(5):
        a = rng.uniform(-0.3, 0.3, (2, robot.n))
        theta.append(a[0] * np.sin(np.pi * s)[:, None] + a[1] * s[:, None] ** 2)
        labels += [f"motion{p}"] * len(s)
    theta = np.vstack(theta)
    m = len(commanded_cables(robot))
    kinds = np.zeros(len(theta), np.uint8)
    obs, ok = plant.predict(robot, np.zeros(plant.size(robot)), theta, np.zeros((len(theta), m)), kinds)
    assert ok.all()
    y = obs[:, :3] + noise * rng.standard_normal((len(theta), 3))
    if jumps:  # a fraction of the readings sqrt(10) times noisier: heavy tails
        y += 3.0 * noise * rng.standard_normal((len(theta), 3)) * (rng.random((len(theta), 1)) < jumps)
    if trend is not None:
        y += np.array([trend(i % 60, i // 60) for i in range(len(theta))])
    meas = Measurements("absolute", robot.n, np.zeros((len(theta), m)), y, theta=theta,
                        labels={"pattern": labels}, fold_groups="pattern", sampled=True)
    return robot, meas


def test_the_noise_of_neighbouring_rows_finds_the_noise_put_in():
    robot, meas = _sampled(SIGMA)
    prep = diagnosis.prepare(robot, meas, frame="base")
    var, ss, nu = diagnosis.neighbour_noise(prep)
    # 5 motions x 58 triples x 3 axes, effective dof 18/35 of them (less only as far as the draws' kurtosis
    # exceeds a Gaussian's)
    assert 0.8 * round(18 * 5 * 58 * 3 / 35) <= nu <= round(18 * 5 * 58 * 3 / 35)
    lo, hi = (diagnosis.stats.chi2_ppf(q, nu) / nu for q in (1e-4, 1 - 1e-4))
    assert lo < var / SIGMA ** 2 < hi


def test_the_interval_of_the_noise_holds_for_heavy_tailed_readings():
    # 5 % of the readings sqrt(10) times noisier (sd of a reading sqrt(0.95 + 0.05 * 10) = 1.20 sigma,
    # kurtosis 8.5): the estimate's 95 % interval must cover the truth about 95 % of the time; with the
    # Gaussian degrees of freedom it is too narrow and misses far more often
    truth = SIGMA * np.sqrt(0.95 + 0.05 * 10.0)
    covered, shrunk = 0, []
    for seed in range(20):
        robot, meas = _sampled(SIGMA, seed=seed, jumps=0.05)
        var, _, nu = diagnosis.neighbour_noise(diagnosis.prepare(robot, meas, frame="base"))
        lo, hi = (var * nu / diagnosis.stats.chi2_ppf(q, nu) for q in (0.975, 0.025))
        covered += lo < truth ** 2 < hi
        shrunk.append(nu / round(18 * 5 * 58 * 3 / 35))
    assert covered >= 17  # (with the Gaussian degrees of freedom: 14 of these 20)
    assert np.median(shrunk) < 0.6


def test_a_smooth_error_shared_by_neighbours_is_not_noise():
    # an offset and a drift along each motion (linear in the row): second differences remove them exactly
    robot, plain = _sampled(SIGMA)
    _, drifted = _sampled(SIGMA, trend=lambda i, p: np.array([1e-3, -2e-3, 5e-4]) * (1 + p) + 3e-5 * i)
    a = diagnosis.neighbour_noise(diagnosis.prepare(robot, plain, frame="base"))
    b = diagnosis.neighbour_noise(diagnosis.prepare(robot, drifted, frame="base"))
    assert a[2] == b[2]
    assert b[0] == pytest.approx(a[0], rel=1e-6)


def test_a_diagnosis_of_sampled_data_estimates_its_noise_and_says_what_it_allows():
    robot, meas = _sampled(SIGMA)
    d = diagnosis.diagnose(robot, meas, effects=["cable_offset"], folds=5, frame="base")
    assert d.noise_estimate.source == "neighbours"
    lo, hi = d.noise_estimate.ci
    assert lo < SIGMA < hi
    assert "neighbouring rows" in d.support_rule and "repeat" in d.support_limits
    assert d.prep.group_column == "pattern" and d.prep.group_count == 5
    # nothing to explain: the data are the nominal model plus noise
    assert d.verdict == "no gap"


def test_an_error_neighbours_share_is_no_outlier_list_but_a_missing_effect():
    # a slow wave along each motion (1 mm, outside the library): every row is "beyond 5 sigma" of the
    # neighbours' noise, so the summary names a few rows, counts them all and says what so many mean
    from cdsm.report import diagnosis as report

    robot, meas = _sampled(SIGMA, trend=lambda i, p: 1e-3 * np.sin(np.pi * i / 59) * np.array([1.0, 0.5, 0.0]))
    d = diagnosis.diagnose(robot, meas, effects=["cable_offset"], folds=5, frame="base")
    assert d.noise_estimate.source == "neighbours" and len(d.outliers) > report.OUTLIERS_SHOWN
    line = next(t for t in report.summary(d) if t.startswith("Rows with a residual"))
    assert f"({len(d.outliers)} rows in all; the JSON lists every one)" in line
    assert line.count("row ") == report.OUTLIERS_SHOWN
    assert "cannot all be outliers" in line and "neighbours share" in line
    assert len(d.to_json()["outliers"]) == len(d.outliers)


def test_an_elastic_arms_features_are_those_of_its_equilibrium(v4):
    # where the gap lies is judged against where the arm is: a tendon pulled alone bends the tip towards it,
    # the eight paid out hang slack (the recording's tendon-pull pattern)
    prep = diagnosis.prepare(v4, read_for(v4, "ftdcr_v4_tendon_pull"))
    f = diagnosis.features(prep)
    labels = prep.meas.labels["pattern_label"]
    pulls = -prep.dL
    i = max((j for j in range(len(labels)) if "tendon0" in labels[j]), key=lambda j: pulls[j, 0])
    assert pulls[i, 0] > 4e-3
    assert f["most pulled cable (index)"][i] == 1.0
    assert f["slack cables (count)"][i] == 8.0
    assert f["tip bend (rad)"][i] > 0.3 and f["max cable tension (N)"][i] > 1.0
    assert f["tip bend (rad)"][0] < 0.02  # the first row: every servo within 0.11 mm of home
    # the tip of a bent arm is nearer the base along the backbone than the straight arm's 186.5 mm
    assert f["X (m)"][i] < 0.1865 - 1e-3
