"""What the calling process and the workers share: the words they say to each other (`protocol`),
the shared memory both read and write (`buffers`) and the signals that wake each other (`sync`).
Imported by both sides; imports neither."""
