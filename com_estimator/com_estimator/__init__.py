"""Estimator node for object mass and COM from wrist F/T wrenches, and offline bag replay."""
