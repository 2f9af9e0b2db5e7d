"""System identification from recorded bags (paper Sec. 3-4, Fig. 5-9), and the paper's figures.

One module pair per identified part: ``<kind>_fit`` holds the fits (numpy/scipy/python-control,
no rclpy, unit-tested alone) and ``<kind>_cli`` reads a bag, fits, prints identified against
configured values and draws the paper's figure. :mod:`.cli` is the ``sysid`` executable.
"""
