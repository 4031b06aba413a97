"""The model-plant-mismatch benchmark: labelled scenarios, every method on every run, scoring, the dataset.

* :mod:`.units`: the four units (Wood-Berry, the 3x3, the debutanizer 4x8, a 16x16 sparse unit);
* :mod:`.scenarios`: the rule that draws the labelled runs, and the committed
  scenario file ``config/benchmark_scenarios.csv`` it wrote;
* :mod:`.runner`: one run simulated (the lockstep batch core) and diagnosed by every method;
* :mod:`.scoring`: detection at a fixed false-alarm rate, ROC, localisation,
  quantification error, coverage, inconclusive rate, CPU time;
* :mod:`.dataset`: the exported runs (r, u, y as Parquet, the models, the labels), read with pandas alone;
* :mod:`.markdown`, :mod:`.plots`: the markdown report and its figures.

Numpy, scipy, pandas and matplotlib; nothing here imports ROS or the command layer.
"""
