"""A tiny robot project: a roslibpy controller that takes the demo arm to the box and back."""
