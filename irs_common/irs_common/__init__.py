"""Node plumbing shared by the IRS nodes (the only IRS modules besides the nodes that import rclpy)."""
