"""The page's Fourier synthesis (static/synthesis.js, run by node) against nnmstop.fourier on the same coefficients."""

from __future__ import annotations

import json
import shutil
import subprocess
from importlib import resources

import numpy as np
import pytest

from nnmstop import fourier

NODE = shutil.which("node")
pytestmark = pytest.mark.skipif(
    NODE is None, reason="node (Node.js) is not installed: the JS synthesis is checked in the browser test only"
)

RUNNER = """
const S = require(process.argv[1]);
const input = JSON.parse(require("fs").readFileSync(0, "utf8"));
const out = input.cases.map(function (c) {
  const sin = c.sin ? Float64Array.from(c.sin) : null;
  const r = S.synthesize(Float64Array.from(c.cos), sin, Int32Array.from(c.harmonics), c.samples);
  return { values: Array.from(r.values), derivative: Array.from(r.derivative) };
});
process.stdout.write(JSON.stringify(out));
"""


def run_js(cases: list) -> list:
    script = resources.files("nnmstop.explorer").joinpath("static/synthesis.js")
    result = subprocess.run(
        [NODE, "-e", RUNNER, str(script)],
        input=json.dumps({"cases": cases}),
        capture_output=True,
        text=True,
        check=True,
    )
    return json.loads(result.stdout)


def test_js_synthesis_matches_nnmstop_fourier():
    rng = np.random.default_rng(7)
    H, m = 40, 256
    cos = rng.normal(size=H + 1) / (1 + np.arange(H + 1)) ** 2
    sin = rng.normal(size=H + 1) / (1 + np.arange(H + 1)) ** 2
    sin[0] = 0.0
    odd = np.arange(1, H + 1, 2)  # a subset of harmonics, as the page keeps them
    cases = [
        {"cos": cos.tolist(), "sin": sin.tolist(), "harmonics": list(range(H + 1)), "samples": m},
        {
            "cos": cos[odd].astype(np.float32).astype(float).tolist(),
            "sin": None,
            "harmonics": odd.tolist(),
            "samples": m,
        },
    ]
    full, cosine_only = run_js(cases)

    theta = 2 * np.pi * np.arange(m) / m
    reference = fourier.PhaseSynthesis(theta, H)
    np.testing.assert_allclose(
        full["values"], fourier.to_time(fourier.from_cos_sin(cos, sin), H, m), rtol=0, atol=1e-13
    )
    np.testing.assert_allclose(full["derivative"], reference.theta_derivative(cos, sin), rtol=0, atol=1e-12)

    kept = np.zeros(H + 1)
    kept[odd] = np.float32(cos[odd])
    np.testing.assert_allclose(cosine_only["values"], fourier.to_time(kept, H, m), rtol=0, atol=1e-13)
    np.testing.assert_allclose(
        cosine_only["derivative"], reference.theta_derivative(kept, np.zeros(H + 1)), rtol=0, atol=1e-12
    )
