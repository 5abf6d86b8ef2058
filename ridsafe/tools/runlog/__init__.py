"""The run log: one MCAP file of JSON records per run (the record schema is
``ridsafe.common.topics``, since the apps write the records).

- ``writer``: ``McapRecorder``, the ``LogSink`` of a real run, and its plug-in interface.
- ``child_writer``: ``RecorderProcess``, the same writer in a child process.
- ``foxglove_channels``: the Foxglove views, a writer plug-in (messages built in
  ``foxglove_scenes``, schemas in ``foxglove_schemas``).
- ``reader``: ``read_records``, tolerant of a cut-off tail.
- ``merge``: ``merge_parts``, the part logs of a live run into one.
"""
