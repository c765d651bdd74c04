"""Running a whole cell for a while: the nodes in one process or each in its own, an observer
that counts and times what flows, and the loop benchmark. The bringup and the tests use it."""
