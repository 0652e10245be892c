"""The explorer's atlas view (static/atlas.js) run by node against a stand-in page: what a click draws."""

from __future__ import annotations

import json
import shutil
import subprocess
from importlib import resources

import numpy as np
import pytest
import xarray as xr

from nnmstop.explorer.extract import extract_atlas
from nnmstop.explorer.page import encode

NODE = shutil.which("node")
pytestmark = pytest.mark.skipif(NODE is None, reason="node (Node.js) is not installed: the browser test checks it")

# A stand-in for the page: elements by id, Plotly.react recording what it draws; the page's scripts run in it.
RUNNER = """
const vm = require("vm"), fs = require("fs");
const [synthesis, atlas, dataPath, request] = process.argv.slice(1);
const elements = {};
const element = (id) => elements[id] || (elements[id] = { id, hidden: true, textContent: "", value: "",
  appendChild() {}, addEventListener() {}, on() {} });
const ctx = { console, Buffer, document: { getElementById: element, createElement: () => ({}) },
  Plotly: { react(id, traces, layout) { ctx.drawn[id] = { traces, layout }; } }, drawn: {} };
ctx.window = ctx;
ctx.self = ctx;
vm.createContext(ctx);
vm.runInContext(fs.readFileSync(synthesis, "utf8"), ctx);
ctx.explorer = { data: ctx.Synthesis.unpackAll({ atlases: [JSON.parse(fs.readFileSync(dataPath, "utf8"))] }) };
vm.runInContext(fs.readFileSync(atlas, "utf8"), ctx);
const r = JSON.parse(request);
const shown = r.curve !== undefined ? ctx.atlas.showCurvePoint(r.curve) : ctx.atlas.showRegion(r.f, r.s);
const orbit = ctx.drawn["atlas-orbit"].traces.filter((t) => !t.xaxis).map((t) => ({ name: t.name, y: t.y }));
process.stdout.write(JSON.stringify({ shown, orbit, map: ctx.drawn["atlas-plot"].traces.length,
  section: elements["atlas-section"].hidden }));
"""


@pytest.fixture(scope="module")
def atlas_record(small_build, tmp_path_factory):
    path = "results/atlas/oscillator_force.nc"
    slices = sorted((small_build / "results/atlas/oscillator_force").glob("slice_*.nc"))
    record = extract_atlas(path, [s.relative_to(small_build) for s in slices], {}, root=small_build)
    data = tmp_path_factory.mktemp("atlas_js") / "atlas.json"
    data.write_text(json.dumps(encode(record)))
    return data, xr.open_dataset(small_build / path).load()


def run(data, request: dict) -> dict:
    static = resources.files("nnmstop.explorer").joinpath("static")
    result = subprocess.run(
        [NODE, "-e", RUNNER, str(static / "synthesis.js"), str(static / "atlas.js"), str(data), json.dumps(request)],
        capture_output=True, text=True, check=True,
    )  # fmt: skip
    return json.loads(result.stdout)


def test_a_clicked_curve_point_draws_its_orbit(atlas_record):
    """The orbit drawn for a curve point peaks at the dataset's amplitude of x there (256 phases drawn)."""
    data, ds = atlas_record
    i = ds.sizes["point"] // 2
    out = run(data, {"curve": i})
    assert out["section"] is False and out["map"] >= ds.sizes["curve"] + 1
    x = np.array(next(t["y"] for t in out["orbit"] if t["name"].startswith("x")))
    assert np.abs(x).max() == pytest.approx(float(ds["amplitude"].values[i, 0]), rel=1e-3)
    assert f"{float(ds['frequency'].values[i]):.6f}" in out["shown"]


def test_a_clicked_region_draws_every_response_of_the_nearest_slice(atlas_record):
    """In the jump region the nearest slice has three responses there: two stable, one unstable."""
    data, ds = atlas_record
    cells = np.argwhere(ds["region"].values == 2)
    k, j = cells[len(cells) // 2]
    f, s = float(ds["grid_frequency"].values[j]), float(ds["slice_value"].values[k])
    out = run(data, {"f": f, "s": s})
    assert out["shown"]["region"] == "coexisting"
    assert out["shown"]["responses"] == int(ds["responses"].values[k, j]) == 3
    names = [t["name"] for t in out["orbit"] if t["name"].startswith("x")]
    assert sum("unstable" in n for n in names) == 1
