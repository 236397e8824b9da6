"""The exploration's sequence over ports (no ROS): what the sequencer node drives through
adapters of its own, each port a file (``ports``), the arm's and the gripper's motion on them
(``motion``), and the errors that end a run (``errors``)."""
