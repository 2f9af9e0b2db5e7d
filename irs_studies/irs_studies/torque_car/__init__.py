"""The torque car's experiments from their bags: metrics, plots and the CLI.

:mod:`.series` reads a run's bag into arrays, :mod:`.metrics` computes the braking and
step-steer metrics (pure numpy), :mod:`.plots` draws the figures, :mod:`.cli` is
``./irs run irs_studies torque_car``.
"""
