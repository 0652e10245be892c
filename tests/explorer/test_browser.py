"""dist/explorer.html in a real browser: headless Debian Chromium driven by Playwright (no browser download).

Skipped where Chromium or the Python ``playwright`` client is missing; ``.ci/run`` installs Debian's
``chromium`` and sets ``NNMSTOP_REQUIRE_BROWSER=1``, which turns the skip into a failure. Set
``NNMSTOP_EXPLORER_SCREENSHOT=<file.png>`` to keep the screenshot (it is always written under the
test's temporary folder).
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from nnmstop import fourier

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
# The flags of the machine notes: no background traffic, no sandbox (root in CI), no GPU.
ARGS = [
    "--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking", "--disable-component-update",
    "--no-first-run", "--disable-sync", "--disable-quic",
]  # fmt: skip


def _missing() -> str | None:
    if CHROMIUM is None:
        return "no Chromium installed (Debian: apt-get install -y chromium)"
    try:
        import playwright.sync_api  # noqa: F401
    except ImportError:
        return "the Python playwright client is not installed (environment.lock)"
    return None


@pytest.fixture(scope="module")
def browser_page(small_build, tmp_path_factory):
    """The small build's explorer opened at 1280 x 800, with its console messages and requests."""
    reason = _missing()
    if reason:
        if os.environ.get("NNMSTOP_REQUIRE_BROWSER") == "1":
            pytest.fail(f"NNMSTOP_REQUIRE_BROWSER=1 but {reason}")
        pytest.skip(reason)
    from playwright.sync_api import sync_playwright

    profile = tmp_path_factory.mktemp("chromium_profile")
    with sync_playwright() as playwright:
        context = playwright.chromium.launch_persistent_context(
            str(profile), executable_path=CHROMIUM, args=ARGS, headless=True, viewport={"width": 1280, "height": 800}
        )
        page = context.new_page()
        log = {"console": [], "requests": []}
        page.on("console", lambda message: log["console"].append((message.type, message.text)))
        page.on("pageerror", lambda error: log["console"].append(("pageerror", str(error))))
        page.on("request", lambda request: log["requests"].append(request.url))
        url = (small_build / "dist/explorer.html").resolve().as_uri()
        page.goto(url)
        page.wait_for_selector("body[data-ready=true]", timeout=60_000)
        yield page, log, url
        context.close()


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
    assert page.evaluate("window.explorer.state.firstRender") > 0


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

    for name in ("energy", "frequency", "x_max"):
        text, value = shown(page, name)
        assert value == float(ds[name][i])
        assert float(text.split()[0]) == pytest.approx(float(ds[name][i]), rel=1e-6)

    # the page's orbit: the dataset's float32 coefficients synthesized on the page's grid
    samples = page.evaluate("window.explorer.samples")
    _, synthesized = shown(page, "x-max-synthesized")
    cos = ds["x_cos"].values[i]
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
