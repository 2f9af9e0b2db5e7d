"""irs_treadmill."""
