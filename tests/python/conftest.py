"""pytest set-up: golden-image fixture (penumbra.testing)."""

pytest_plugins = ["penumbra.testing"]
