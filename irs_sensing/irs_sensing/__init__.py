"""irs_sensing."""
