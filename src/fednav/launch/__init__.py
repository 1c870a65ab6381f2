"""Navigation in the launch inertial frame (paper 001): frame and gravitation, ascent
trajectories, strapdown mechanization, error model and the federated PF/EKF loop."""
