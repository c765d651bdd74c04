"""The control laws (FBCC, the robust law, the admittance baseline), their design and the
supervisor that runs them."""
