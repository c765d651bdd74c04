"""mcap bags, rosbag2-compatible: schemas, writing, reading (a truncated bag included)."""
