"""Files in and out: spec files, part kinds, scenes, the writers of every format, previews."""
