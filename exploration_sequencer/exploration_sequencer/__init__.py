"""Sequencer that tares, grasps and tilts the wrist to explore an object, and records each run"""
