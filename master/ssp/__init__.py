"""Reading and writing SSP (System Structure and Parameterization) scenarios."""
