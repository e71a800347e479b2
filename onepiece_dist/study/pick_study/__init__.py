"""A study on pick labels (issue 58, docs/studies/pick_labels): arms as sets of rows of the pick labels (arms), the
typed record a study writes (result) and its page (page). The flow that fits and judges the arms is
benchmarks/experiments/pick_study.py."""
