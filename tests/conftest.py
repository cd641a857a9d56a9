"""pytest loads this file first in every worker (also under pytest-xdist), which puts tests/ on
sys.path, so that the shared helpers here (headless, landings) import from any test directory."""
