"""Code the tests and the benches share that the product does not use."""
