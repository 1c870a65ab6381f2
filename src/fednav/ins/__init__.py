"""Inertial navigation: the strapdown mechanization (ENU), its 18-state error model,
the total-state (direct) filter of paper 003, alignment and observability analysis."""
