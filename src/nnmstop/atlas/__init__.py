"""The bifurcation atlas (issue 31): where a forced structure impacts, jumps and stops being periodic."""
