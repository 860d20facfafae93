"""Code generation stage: validated model -> topology -> symbolic equations -> C."""
