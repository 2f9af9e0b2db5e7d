"""The driver: the speed profile (:mod:`.speed_profile`, no rclpy) and its node (``driver``)."""
