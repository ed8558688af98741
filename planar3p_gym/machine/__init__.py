"""The machine: design parameters, exact kinematics, statics and smooth motions.

Numpy only: nothing here knows of pymunk or Gymnasium.
"""
