"""Estimator node for object mass and centre of mass from wrist F/T wrenches, and offline bag replay"""
