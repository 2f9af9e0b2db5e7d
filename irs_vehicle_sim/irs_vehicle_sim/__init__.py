"""irs_vehicle_sim."""
