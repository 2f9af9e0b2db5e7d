"""The real rig behind the simulator's topics: device drivers, calibration, safety, emulators."""
