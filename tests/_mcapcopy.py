"""A recording rewritten through the ``mcap`` package's own writer: the tests' files in another
writer's layout (no indexes, no calibration record, extra channels)."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any


def copy_records(reader: Any, writer: Any, *, keep: Callable[[str], bool] = lambda _: True) -> None:
    """Every schema, channel and message of ``reader`` (an ``mcap`` reader) into ``writer`` (a
    started ``mcap`` Writer), in file order, then the metadata records whose name ``keep``
    accepts."""
    schemas: dict[int, int] = {}
    channels: dict[int, int] = {}
    for schema, channel, message in reader.iter_messages(log_time_order=False):
        if channel.id not in channels:
            if schema is not None and schema.id not in schemas:
                schemas[schema.id] = writer.register_schema(
                    schema.name, schema.encoding, schema.data
                )
            channels[channel.id] = writer.register_channel(
                channel.topic,
                channel.message_encoding,
                schemas[schema.id] if schema is not None else 0,
                dict(channel.metadata),
            )
        writer.add_message(
            channels[channel.id], message.log_time, message.data, message.publish_time
        )
    for record in reader.iter_metadata():
        if keep(record.name):
            writer.add_metadata(record.name, dict(record.metadata))
