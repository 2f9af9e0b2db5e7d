"""Markdown tables of the torque car's metrics (the README's and docs/torque_car.md's tables)."""
from __future__ import annotations

import math

__all__ = ['braking_table', 'step_steer_table']


def _f(v, fmt: str) -> str:
    if isinstance(v, bool):
        return 'yes' if v else 'no'
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return '–'
    return fmt.format(v)


def _wheels(vs, fmt: str) -> str:
    return ' / '.join(_f(v, fmt) for v in vs)


def braking_table(rows: dict) -> str:
    """``rows``: run name -> braking metrics; one Markdown table."""
    head = ('| run | u at brake [m/s] | stop [m] | stop [s] | mean decel [m/s^2] | '
            'slip mean FL/FR/RL/RR (truth) | slip min | slip median (controller) | '
            'wheel locked [s] | peak yaw rate [rad/s] | heading at stop [rad] | '
            'drift back at stop / by the end [m] | to belt end [m] | belt speed min [m/s] | '
            'ref. speed error max [m/s] | mean slip target |')
    lines = [head, '|' + '---|' * (head.count('|') - 1)]
    for name, m in rows.items():
        lines.append(' | '.join([
            f'| {name}', _f(m['u_brake'], '{:.3f}'), _f(m['stopping_distance'], '{:.3f}'),
            _f(m['stopping_time'], '{:.3f}'), _f(m['mean_deceleration'], '{:.2f}'),
            _wheels(m['slip_mean'], '{:.3f}'), _wheels(m['slip_min'], '{:.2f}'),
            _wheels(m['slip_est_median'], '{:.3f}'), _wheels(m['locked_time'], '{:.3f}'),
            _f(m['peak_yaw_rate'], '{:.3f}'), _f(m['heading_at_stop'], '{:.3f}'),
            _wheels((m['drift_at_stop'], m['drift_back']), '{:.3f}'),
            _f(m['belt_end_margin'], '{:.2f}'),
            _f(m['belt_speed_min'], '{:.3f}'), _f(m.get('v_ref_error_max'), '{:.3f}'),
            _f(m.get('slip_target_mean'), '{:.3f}')]) + ' |')
    return '\n'.join(lines)


def step_steer_table(rows: dict) -> str:
    """``rows``: run name -> step-steer metrics; one Markdown table."""
    lines = ['| run | steer [rad] | r_ref at step / end [rad/s] | 90 % rise [s] | overshoot [%] | '
             'ISE [rad^2/s] | steady error [rad/s] | peak rear steer [rad] | peak dT [N m] |',
             '|---|---|---|---|---|---|---|---|---|']
    for name, m in rows.items():
        lines.append(' | '.join([
            f'| {name}', _f(m['amplitude'], '{:.3f}'),
            _wheels((m['r_ref0'], m['r_ref_end']), '{:.4f}'),
            _f(m['rise_time_90'], '{:.3f}'), _f(m['overshoot_percent'], '{:.1f}'),
            _f(m['ise'], '{:.2e}'), _f(m['steady_state_error'], '{:.1e}'),
            _f(m['peak_rear_steer'], '{:.4f}'), _f(m['peak_differential_torque'], '{:.4f}')])
            + ' |')
    return '\n'.join(lines)
