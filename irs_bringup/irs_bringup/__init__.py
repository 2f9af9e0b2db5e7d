"""irs_bringup."""
