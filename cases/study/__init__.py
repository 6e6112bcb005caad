"""The soil-study library every runnable case is built on.

Modules, from the files a user writes to the figures a run draws:
- ``programme``: the test record (``TestSpec``), one for every test type;
- ``checks``, ``entries``, ``schema``: the study file (TOML) read and checked into a ``Study`` (the base models
  it can name: ``constitutive.registry``); ``presets``: the pressuremeter FE and sampler sizes;
- ``records``: the recording CSVs read and checked into ``inference`` observations, and the record writer;
- ``lab_forward``, ``sbp_forward``, ``forward``: the forward models (laboratory drivers, pressuremeter FE, a study's
  whole programme);
- ``generate``: SYNTHETIC recordings from the forward model;
- ``problem``: the study as a problem of the calibrate -> diagnose loop (``inference.diagnosis.run_loop``);
- ``runner``: the runs of one command line, one TMCMC run, summary.json; ``cli``: the shared command line;
- ``outputs``, ``sbp_outputs``: tables, figures and reports.

The names below are the ones the runnable cases share.
"""
