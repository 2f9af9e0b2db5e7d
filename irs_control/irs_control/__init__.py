"""irs_control."""
