"""Offline explorer of the datasets: one self-contained HTML page (issue 24; docs/explorer.md).

* :mod:`.extract`: datasets -> the explorer's data; the only module that knows the datasets' layout
  (a kind of branch is one entry of ``extract.KINDS``);
* :mod:`.exact_orbits`: exact orbits rebuilt in closed form from the stored start velocities;
* :mod:`.page`: the page, from the template and scripts in ``static/`` and the plotting library
  vendored in ``vendor/`` (plotly.js, pinned), everything inlined.
"""
