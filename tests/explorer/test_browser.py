"""dist/explorer.html in a real browser: headless Debian Chromium driven by Playwright (no browser download).

Skipped where Chromium or the Python ``playwright`` client is missing; ``.ci/run`` installs Debian's
``chromium`` and sets ``NNMSTOP_REQUIRE_BROWSER=1``, which turns the skip into a failure. Set
``NNMSTOP_EXPLORER_SCREENSHOT=<file.png>`` to keep the screenshot (it is always written under the
test's temporary folder).
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from nnmstop import fourier
from nnmstop.explorer.browser import missing_browser, open_page
from nnmstop.explorer.extract import file_sha256


@pytest.fixture(scope="module")
def browser_page(request):
    """The small build's explorer opened at 1280 x 800, with its console messages and requests."""
    reason = missing_browser()
    if reason:
        if os.environ.get("NNMSTOP_REQUIRE_BROWSER") == "1":
            pytest.fail(f"NNMSTOP_REQUIRE_BROWSER=1 but {reason}")
        pytest.skip(reason)
    small_build = request.getfixturevalue("small_build")  # built only where the browser can open it
    with open_page(small_build / "dist/explorer.html") as opened:
        yield opened


def shown(page, name: str) -> tuple[str, float]:
    """Text and exact value of a row of the selected orbit's numbers."""
    cell = page.locator(f"#value-{name}")
    return cell.inner_text(), float(cell.get_attribute("data-value"))


def branch_index(page, path: str) -> int:
    return page.evaluate("p => window.explorer.branches.findIndex(b => b.path === p)", path)


def click_point(page, energy: float, frequency: float) -> None:
    """Click the frequency-energy plot where (energy, frequency) is drawn."""
    x, y = page.evaluate(
        """([E, f]) => {
            const gd = document.getElementById("fep"), L = gd._fullLayout, box = gd.getBoundingClientRect();
            return [box.left + L._size.l + L.xaxis.l2p(Math.log10(E)), box.top + L._size.t + L.yaxis.l2p(f)];
        }""",
        [energy, frequency],
    )
    page.mouse.click(x, y)


def grid_peak_error(cos: np.ndarray, samples: int) -> float:
    """Bound on how far the maximum over ``samples`` uniform phases lies below the true maximum:
    half the largest |x''(theta)| times the squared half-spacing."""
    k = np.arange(cos.size)
    return 0.5 * np.sum(k**2 * np.abs(cos)) * (np.pi / samples) ** 2


def test_loads_offline_with_no_console_error(browser_page):
    page, log, url = browser_page
    assert [m for m in log["console"] if m[0] in ("error", "pageerror")] == []
    assert set(log["requests"]) == {url}  # the page itself, nothing fetched
    assert page.locator("#fep .scatterlayer .trace").count() > 5
    assert page.evaluate("window.explorer.timings.ready") > 0


def test_clicked_nnm1_point_shows_its_dataset_values(browser_page, small_build):
    page, _, _ = browser_page
    ds = xr.open_dataset(small_build / "results/hbm/nnm1.nc")
    energy, frequency = ds["energy"].values, ds["frequency"].values
    target = int(np.flatnonzero(energy > 0.2)[0])  # low energy: only NNM1 is drawn near it
    click_point(page, energy[target], frequency[target])
    state = page.evaluate("[window.explorer.state.branch, window.explorer.state.point]")
    assert state[0] == branch_index(page, "results/hbm/nnm1.nc")
    i = state[1]
    assert abs(np.log(energy[i] / energy[target])) < 0.05  # the click landed on the target or a neighbour

    assert page.locator("#value-dataset").inner_text() == "results/hbm/nnm1.nc"
    assert page.locator("#value-sha256").inner_text() == file_sha256(small_build / "results/hbm/nnm1.nc")
    for name in ("energy", "frequency", "x_max"):
        text, value = shown(page, name)
        assert value == float(ds[name][i])
        assert float(text.split()[0]) == pytest.approx(float(ds[name][i]), rel=1e-6)

    # the page's orbit: the dataset's float32 coefficients synthesized on the page's grid
    samples = page.evaluate("window.explorer.samples")
    _, synthesized = shown(page, "x-max-synthesized")
    cos = ds["q_cos"].values[i, list(ds["dof_label"].values).index("x")]
    H = cos.size - 1
    page_grid = fourier.to_time(cos.astype(np.float32).astype(float), H, samples).max()
    assert synthesized == pytest.approx(page_grid, rel=1e-9)
    dataset_samples = int(ds.attrs["time_samples"])
    tolerance = grid_peak_error(cos, samples) + grid_peak_error(cos, dataset_samples) + 1e-6 * abs(cos).sum()
    assert abs(synthesized - float(ds["x_max"][i])) <= tolerance


def test_keyboard_moves_between_points_and_branches(browser_page, small_build):
    page, _, _ = browser_page
    nnm1 = branch_index(page, "results/hbm/nnm1.nc")
    page.evaluate("i => window.explorer.select(i, 5)", nnm1)
    page.focus("#fep")
    energy = xr.open_dataset(small_build / "results/hbm/nnm1.nc")["energy"].values
    page.keyboard.press("ArrowRight")
    assert page.evaluate("window.explorer.state.point") == 6
    assert shown(page, "energy")[1] == float(energy[6])
    page.keyboard.press("PageUp")
    assert page.evaluate("window.explorer.state.point") == 16
    page.keyboard.press("ArrowLeft")
    page.keyboard.press("Home")
    assert page.evaluate("window.explorer.state.point") == 0
    page.keyboard.press("ArrowUp")
    assert page.evaluate("window.explorer.state.branch") != nnm1
    assert page.locator("#value-branch").inner_text() != ""


def test_screenshot_at_1280_by_800(browser_page, tmp_path):
    page, log, _ = browser_page
    nnm1 = branch_index(page, "results/hbm/nnm1.nc")
    points = page.evaluate("i => window.explorer.branches[i].points", nnm1)
    page.evaluate("([i, p]) => window.explorer.select(i, p)", [nnm1, int(points * 0.85)])
    target = Path(os.environ.get("NNMSTOP_EXPLORER_SCREENSHOT") or tmp_path / "explorer.png")
    page.screenshot(path=str(target))
    assert target.stat().st_size > 20_000
    assert [m for m in log["console"] if m[0] in ("error", "pageerror")] == []


def test_overlay_pairs_the_same_nnm_at_the_same_energy(browser_page, small_build):
    """A regularized NNM1 orbit with impacts is overlaid with an exact NNM1 orbit of as many impacts within 5 % in
    energy; NNM2 has no exact counterpart, so none."""
    page, _, _ = browser_page
    nnm1, nnm2 = (branch_index(page, f"results/hbm/{name}.nc") for name in ("nnm1", "nnm2"))
    exact = branch_index(page, "results/exact/nnm1.nc")
    regular = xr.open_dataset(small_build / "results/hbm/nnm1.nc")
    exact_ds = xr.open_dataset(small_build / "results/exact/nnm1.nc")
    i = int(np.flatnonzero(regular["impacts_per_period"].values == 2)[-1])
    partner = page.evaluate("([b, i]) => window.explorer.partnerOf(b, i)", [nnm1, i])
    assert partner["branch"] == exact
    j = partner["point"]
    assert exact_ds["impacts_per_period"].values[j] == 2
    assert abs(np.log(exact_ds["energy"].values[j] / regular["energy"].values[i])) <= 0.05
    assert page.evaluate("b => window.explorer.partnerOf(b, 3)", nnm2) is None


def test_the_atlas_shows_the_orbit_of_a_curve_point_and_the_responses_of_a_region(browser_page, small_build):
    """The small atlas below the branches: a curve point's orbit, and in the jump region between the folds the
    two stable responses of the nearest slice (and the unstable one between them)."""
    page, log, _ = browser_page
    assert page.evaluate("() => window.atlas.atlases.length") == 1
    text = page.evaluate("() => window.atlas.showCurvePoint(0)")
    assert "Hz" in text
    with xr.open_dataset(small_build / "results/atlas/oscillator_force.nc") as ds:
        region = ds["region"].values
        k, j = np.argwhere(region == 2)[len(np.argwhere(region == 2)) // 2]  # a coexisting cell
        f, s = float(ds["grid_frequency"].values[j]), float(ds["slice_value"].values[k])
    shown = page.evaluate("([f, s]) => window.atlas.showRegion(f, s)", [f, s])
    assert shown["region"] == "coexisting" and shown["responses"] >= 2
    assert not [m for m in log["console"] if m[0] in ("error", "pageerror")]
