//! Unit tests of the ROS layer (`src/ros/`) against r2r's message types and
//! rcl: built only with the feature `ros2` (`.ci/run` runs them after the ROS
//! 2 set-up, reusing the library the nodes were built with).
#![cfg(feature = "ros2")]

mod convert;
mod params;
