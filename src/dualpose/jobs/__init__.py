"""Many-run jobs on a dask scheduler (docs/scaling.md, "Many runs"): many trajectory evaluations
(:mod:`~dualpose.jobs.eval_batch`), the orientation filter over many recordings (:mod:`~dualpose.jobs.ahrs_batch`),
Monte-Carlo runs of the filter on the simulator (:mod:`~dualpose.jobs.monte_carlo`); the scheduler plumbing
(:mod:`~dualpose.jobs.scheduler`), the results table and its summary (:mod:`~dualpose.jobs.table`) and the figures
(:mod:`~dualpose.jobs.figures`).  dask is optional (``pip install 'dualpose[dask]'``): without it the jobs run
serially."""
