"""Process and environment helpers shared by tests, benchmarks and scripts (no rclpy)."""
