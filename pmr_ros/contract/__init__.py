"""The topic contract and everything that reads it without ROS: rclpy-free, shared by nodes and bags.

``topics`` is ``msg_defs/topics.yaml`` (names, types, QoS); ``layout`` the
messages' contents as plain data; ``alignment`` lines r, u, y up by sample
stamp; ``windowing`` decides when and what the diagnostician diagnoses.  The
live node (:mod:`pmr_ros.nodes.pmr_diagnostician`) and the offline diagnosis of
a bag (:mod:`pmr_ros.bag.offline`) both run this code, so they agree.
"""
