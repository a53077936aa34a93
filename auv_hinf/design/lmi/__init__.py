"""Linear matrix inequalities in cvxpy, solved by Clarabel: the only package that imports cvxpy."""
