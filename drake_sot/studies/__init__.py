"""Studies: a scenario run many times (grids, random samples, bisections), described as data
(:mod:`drake_sot.studies.description`) and run on Dask (:mod:`drake_sot.studies.runner`)."""

from drake_sot.studies.description import Bisection, Grid, RandomSample, Run, Study, make_run, plans, run_id

__all__ = ["Bisection", "Grid", "RandomSample", "Run", "Study", "make_run", "plans", "run_id"]
