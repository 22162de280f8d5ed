"""The `brakewear` commands of sim2real: the parser with diagnose and validate-gap (cli.py),
`simulate --effect` (simulate.py), the demo stage (demo.py) and validate-gap's units
(units.py). Each turns its arguments into typed configs; the library below never sees them."""
