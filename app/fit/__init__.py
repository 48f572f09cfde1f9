"""A cage around an image's subject: colour models, growth, doubt, the B-spline fit."""
