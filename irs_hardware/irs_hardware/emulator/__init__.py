"""Emulated devices speaking the real protocols, with the simulated rig behind their pins."""
