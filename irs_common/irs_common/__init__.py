"""Node plumbing shared by the IRS nodes.

The only IRS modules besides the nodes that import rclpy.
"""
