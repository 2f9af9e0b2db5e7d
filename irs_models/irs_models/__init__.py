"""ROS-free models shared by the IRS simulator, estimator and controller.

``constants`` (the rig's dimensions and limits, the identified plant's numbers), ``arm_kinematics``
(the sensing arm, paper Eq. 3), ``identified`` (the identified plant, paper Eq. 6), ``bicycle``
(the linear bicycle model), ``lateral_plant`` (the plant interface the rig steps and the
discretised bicycle plant), ``presets`` (named vehicle presets, ``config/presets.yaml``).
Nothing here imports rclpy or another IRS package: every other package may import this one.
"""
