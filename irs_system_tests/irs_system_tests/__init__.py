"""Graph-level tests of the IRS and their harness: real nodes in real processes on real DDS,
experiments, bags, replay; the ROS domain allocator of test and benchmark runs.
"""
