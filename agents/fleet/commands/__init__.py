"""The fleet's ``brakewear`` command: its parser (light) and its implementation."""
