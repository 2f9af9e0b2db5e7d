"""Real-time loop figures: deadline misses and loop latency, kept as a fixed histogram (no rclpy).

The rig measures its own control loop in real time: the *loop latency* of step k is the wall time
from publishing the arm reading stamped t_k to receiving the steering command stamped t_k; a
*deadline miss* is a step k+1 taken before the command answering step k arrived (the plant then
runs one more period on the older command). Latencies go into a histogram of ``bin_s`` wide bins
up to ``max_s`` (the last bin collects everything above), so percentiles over a run of any length
cost O(1) memory and O(bins) to read. A percentile that falls in that last bin is only known to
be beyond ``max_s``: :func:`format_ms` writes it so (``> 50``), not as the bin's edge.
"""
import numpy as np

#: [s] the reach of the latency histogram (its last bin collects everything beyond)
LATENCY_RANGE = 0.05
#: [%] deadline misses of a run from which its timing is a warning, and an error: at 1 % the
#: plant runs one step in a hundred on a stale steer; the composed graph misses 0.0-0.2 % here
#: over 60 s, a process per node 0.5-10 % (docs/performance.md).
MISS_WARN_PCT, MISS_ERROR_PCT = 1.0, 10.0


def timing_level(summary: dict) -> int:
    """The ``diagnostic_msgs/DiagnosticStatus`` level of a :meth:`LoopTiming.summary`: 0 (OK)
    below :data:`MISS_WARN_PCT` deadline misses, 1 (WARN) below :data:`MISS_ERROR_PCT`, else
    2 (ERROR).
    """
    pct = summary['miss_pct']
    return 0 if pct < MISS_WARN_PCT else 1 if pct < MISS_ERROR_PCT else 2


def format_ms(value_ms: float, range_s: float = LATENCY_RANGE) -> str:
    """A latency [ms] of :meth:`LoopTiming.summary` for a report: ``'0.271'``, or ``'> 50'``
    when it lies beyond the histogram's reach ``range_s`` [s].
    """
    if value_ms >= 1e3 * range_s:
        return f'> {1e3 * range_s:g}'
    return f'{value_ms:.3f}'


class LoopTiming:
    """Counts steps, misses and late ticks; keeps the latency histogram (module docstring)."""

    def __init__(self, bin_s: float = 10e-6, max_s: float = LATENCY_RANGE):
        if not (bin_s > 0 and max_s > bin_s):
            raise ValueError(f'need 0 < bin_s < max_s, got bin_s={bin_s}, max_s={max_s}')
        self.bin_s = bin_s
        self.counts = np.zeros(int(round(max_s / bin_s)) + 1, dtype=np.int64)
        self.steps = 0
        self.misses = 0
        self.late_ticks = 0
        self.max_latency = 0.0

    def add_latency(self, seconds: float):
        """One loop latency [s] (negative values, from clock steps, count as 0)."""
        seconds = max(seconds, 0.0)
        self.counts[min(int(seconds / self.bin_s), self.counts.size - 1)] += 1
        self.max_latency = max(self.max_latency, seconds)

    def step(self, answered: bool):
        """One step taken; ``answered``: the previous step's command had arrived in time."""
        self.steps += 1
        if not answered:
            self.misses += 1

    def percentile(self, q: float) -> float:
        """The q-th percentile [s] of the latencies (upper bin edge), NaN before any."""
        n = int(self.counts.sum())
        if n == 0:
            return float('nan')
        idx = int(np.searchsorted(np.cumsum(self.counts), q / 100.0 * n, side='left'))
        return (idx + 1) * self.bin_s

    def summary(self) -> dict:
        """Figures for a report: counts, miss percentage, latency p50/p99/max [ms]."""
        return {'steps': self.steps, 'deadline_misses': self.misses,
                'miss_pct': 100.0 * self.misses / self.steps if self.steps else 0.0,
                'late_ticks': self.late_ticks, 'latency_samples': int(self.counts.sum()),
                'latency_p50_ms': 1e3 * self.percentile(50),
                'latency_p99_ms': 1e3 * self.percentile(99),
                'latency_max_ms': 1e3 * self.max_latency}
