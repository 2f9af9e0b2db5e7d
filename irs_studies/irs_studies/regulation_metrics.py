"""Metrics of a treadmill regulation run: per speed-change phase, peak error and settling time."""
import numpy as np


def phase_metrics(time, x, x_ref, change_times, band=0.02):
    """For each phase starting at a driver speed change: peak |x - x_ref| [m] and the time after
    the change [s] from which |x - x_ref| stays within ``band`` [m] (NaN: never settles).
    """
    time, err = np.asarray(time), np.asarray(x) - x_ref
    ends = list(change_times[1:]) + [time[-1] + 1.0]
    out = []
    for start, end in zip(change_times, ends):
        sel = (time >= start) & (time < end)
        t, e = time[sel], np.abs(err[sel])
        outside = np.nonzero(e > band)[0]
        if outside.size == 0:
            settle = 0.0
        elif outside[-1] == e.size - 1:
            settle = float('nan')
        else:
            settle = float(t[outside[-1] + 1] - start)
        out.append({'start': float(start), 'peak_error': float(e.max()), 'settling_time': settle})
    return out
