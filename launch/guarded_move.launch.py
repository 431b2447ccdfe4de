"""Guarded move: approach an object with the BioTac, stop on contact, hold 1 N.

ros2 launch tactile_force guarded_move.launch.py [use_sim:=true] [object:=wooden_box]
    [robot:=pa10|ur5|panda | urdf:=FILE [base_link:=L] [tip_link:=L]] [description_topic:=true]
    [model:=/path/model.json] [port:=/dev/ttyACM0] [start_state:=active|inactive|unconfigured]
    [use_sim_time:=true [real_time_factor:=2.0]] [rviz:=true]
"""

import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

from guarded_move_launch_common import make  # noqa: E402


def generate_launch_description():
    return make("guarded_move.yaml")
