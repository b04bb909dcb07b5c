"""The methods of :func:`dcstereo.match`, one module each: its stages and its parameters."""
