"""The evaluation of agents over MJCF bundles, one concept a module (the `eval` command is `commands/eval.py`):

- `loop`: `evaluate`, one agent over a dataset's episodes through the agent protocol, one result dict per episode;
- `phases`: the session with the agent (sealed or in-process) and one phase run from the reset to its end;
- `exploration`: a scene's first visit for agents with a scene prior;
- `outcomes`: why an episode ended as it did;
- `results`: the results folder's files, the run key and resuming;
- `statistics`: summaries with cluster-bootstrap intervals, paired differences, difficulty;
- `tables`: the markdown tables; `pictures`: trajectory pictures;
- `runner`: table rows (agents built or named), balanced bundle subsets and the parallel `run_rows`.

Import from the module that holds a name (``from sdovon_mj.suite.evaluation.loop import evaluate``): this package
re-exports nothing.
"""
