"""rosbag2 bags of pmr_ros runs: writing, reading and offline diagnosis (``rosbags``, no rclpy)."""
