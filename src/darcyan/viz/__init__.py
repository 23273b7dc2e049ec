"""Pictures: scenes, static rendering, interactive HTML, plot style."""
