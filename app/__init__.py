"""The app: GL context, passes, techniques, capture, window and benchmark."""
