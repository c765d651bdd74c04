"""Command-line tools of fbcc_ros."""
