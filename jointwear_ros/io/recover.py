"""Check MCAP files record by record, and rebuild a readable bag from a damaged or unfinished one.

:func:`scan_mcap` walks an MCAP file in stream order, the way a reader
without the summary must: 8-byte magic, then records (1-byte opcode, 8-byte
length, body) until the footer. Record bodies are decoded with the ``mcap``
library's record classes (:class:`mcap.records.Chunk`, ``Schema``,
``Channel``, ``Message``, ``DataEnd``, ``Footer``) and chunks are opened
with :func:`mcap.stream_reader.breakup_chunk` with CRC validation. The
framing loop is our own rather than :class:`mcap.stream_reader.StreamReader`
because a damaged file needs three things that reader does not do: it
silently skips records of unknown opcode (so a zeroed region reads as a run of
empty "opcode 0" records), a record cut short by the end of the file is read
short without an error, and after an error it cannot continue. Here:

- a chunk whose CRC does not match (or that does not decompress/parse) is
  *skipped and reported* (offset, length, time range), never read as valid;
- an invalid opcode or a record that runs past the end of the file stops the
  walk there; the walk then resynchronises on the next chunk that parses and
  passes its CRC (the bytes in between are reported as damaged);
- what remains at the end of the file without a complete record is the
  *truncated tail* (a recorder killed or out of disk space while writing a
  chunk);
- the data-section CRC (``DataEnd``) is checked when present.

:func:`check_bag` turns problems into an :class:`InputDataError` naming the
file and the byte offset (``bag info`` and ``replay`` use it);
:func:`recover_bag` writes every message of every intact chunk, in stream
order, into a new bag (metadata.yaml v9 + an indexed MCAP written with
:class:`~jointwear_ros.io.mcap_bag.McapBagWriter`) and reports what it
recovered and what it skipped. The input is only ever read.
"""

from __future__ import annotations

import json
import mmap
import os
import shutil
import zlib
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from io import BytesIO
from pathlib import Path
from typing import Any

from ..errors import InputDataError
from .metadata import metadata_problem

__all__ = [
    "MAGIC",
    "McapScan",
    "RecoverReport",
    "check_bag",
    "mcap_files",
    "recover_bag",
    "scan_mcap",
]

MAGIC = b"\x89MCAP0\r\n"
_OP_HEADER, _OP_FOOTER, _OP_SCHEMA, _OP_CHANNEL, _OP_MESSAGE, _OP_CHUNK = 0x01, 0x02, 0x03, 0x04, 0x05, 0x06
_OP_DATA_END = 0x0F
_COMPRESSIONS = (b"", b"zstd", b"lz4")
RECOVERED_KEY = "jointwear.recovered"


def _implausible(buf: Any, pos: int, op: int, length: int, size: int, in_data: bool, chunked: bool) -> str:
    """Why the record at ``pos`` cannot be what it claims ('' if it may be): damage, not data."""
    # 0x01-0x0F are the spec's records; 0x80-0xFF are reserved for private records
    if not (0x01 <= op <= 0x0F or op >= 0x80):
        return f"invalid record opcode 0x{op:02x}"
    if pos + 9 + length > size:
        return ""  # runs past the end: the caller tells truncation from damage
    if op == _OP_CHUNK and not _chunk_header_ok(buf, pos, size):
        return "a chunk record whose fields do not add up"
    if op == 0x07 and (length < 6 or 6 + int.from_bytes(buf[pos + 11:pos + 15], "little") != length):
        return "a message index record whose fields do not add up"
    if in_data and chunked and op in (_OP_SCHEMA, _OP_CHANNEL, _OP_MESSAGE):
        # a chunked file keeps these inside chunks: one at top level is a misread length
        return f"a top-level record of opcode 0x{op:02x} among chunks"
    return ""


@dataclass
class McapScan:
    """What a stream-order walk of one MCAP file found."""

    path: str
    size: int
    #: the file starts with the MCAP magic
    magic: bool = False
    #: the magic is followed by a header record
    header: bool = False
    profile: str = ""
    #: a footer and the closing magic were found: the writer finished the file
    complete: bool = False
    #: ``ok``, ``mismatch`` or ``absent`` (no DataEnd, or its CRC is 0)
    data_crc: str = "absent"
    #: the footer's summary CRC: ``ok``, ``mismatch`` or ``absent``
    summary_crc: str = "absent"
    summary_start: int = 0
    chunks: int = 0
    chunks_without_crc: int = 0
    messages: int = 0
    #: chunks skipped: ``{"offset", "length", "reason", "start_ns", "end_ns"}``
    skipped_chunks: list[dict[str, Any]] = field(default_factory=list)
    #: unreadable byte ranges between records (resynchronised after): ``{"offset", "length", "reason"}``
    damaged: list[dict[str, Any]] = field(default_factory=list)
    #: bytes at the end of the file that hold no complete record (0 for a closed file)
    truncated_bytes: int = 0
    truncated_at: int | None = None
    truncated_reason: str = ""
    #: offset where the data section ends (the DataEnd record, or the last good record)
    data_end: int = 0

    @property
    def unfinished_only(self) -> bool:
        """The file is intact as far as it goes but was never closed (a live or killed recording)."""
        return (self.header and not self.complete and not self.skipped_chunks and not self.damaged
                and self.data_crc != "mismatch")

    @property
    def problems(self) -> list[tuple[int, str]]:
        """(offset, what) of every defect, in file order.

        >>> McapScan("x.mcap", 100, magic=True, header=True).problems
        [(100, 'no footer: the file was not closed by its writer')]
        >>> McapScan("x.mcap", 0).problems
        [(0, 'the file is empty (0 bytes)')]
        """
        out: list[tuple[int, str]] = []
        if not self.header:
            out.append((0, "the file is empty (0 bytes)" if not self.size else
                        "no MCAP header after the magic" if self.magic else "no MCAP magic at the start"))
        for c in self.skipped_chunks:
            out.append((int(c["offset"]), f"chunk of {c['length']} bytes {c['reason']}"))
        for d in self.damaged:
            out.append((int(d["offset"]), f"{d['length']} unreadable bytes ({d['reason']})"))
        if self.data_crc == "mismatch":
            out.append((self.data_end, "data section CRC mismatch"))
        if self.summary_crc == "mismatch":
            out.append((self.summary_start, "summary section CRC mismatch (indexes and statistics)"))
        if self.truncated_bytes:
            out.append((int(self.truncated_at or 0),
                        f"the file ends in an incomplete record ({self.truncated_bytes} bytes: {self.truncated_reason})"))
        elif self.header and not self.complete:
            out.append((self.size, "no footer: the file was not closed by its writer"))
        return sorted(out)


def _read_record(kind: Any, body: bytes, length: int | None = None) -> Any:
    from mcap.data_stream import ReadDataStream

    stream = ReadDataStream(BytesIO(body))
    rec = kind.read(stream, length) if length is not None else kind.read(stream)
    return rec


def _chunk_header_ok(buf: Any, pos: int, size: int) -> bool:
    """Whether a plausible Chunk record starts at ``pos`` (used to resynchronise after damage)."""
    if pos + 9 + 40 > size or buf[pos] != _OP_CHUNK:
        return False
    length = int.from_bytes(buf[pos + 1:pos + 9], "little")
    if length < 40 or pos + 9 + length > size:
        return False
    b = pos + 9
    clen = int.from_bytes(buf[b + 28:b + 32], "little")
    if clen > 4 or b + 32 + clen + 8 > pos + 9 + length:
        return False
    if bytes(buf[b + 32:b + 32 + clen]) not in _COMPRESSIONS:
        return False
    dlen = int.from_bytes(buf[b + 32 + clen:b + 40 + clen], "little")
    return 40 + clen + dlen == length


def scan_mcap(path: str | os.PathLike[str], on_record: Callable[[Any], None] | None = None) -> McapScan:
    """Walk ``path`` record by record; ``on_record`` gets each Schema, Channel and Message of intact data.

    Never raises for damaged content (that is reported in the result); raises
    :class:`InputDataError` only if the file cannot be opened.
    """
    from mcap.records import Channel, Chunk, DataEnd, Footer, Header, Message, Schema
    from mcap.stream_reader import breakup_chunk

    p = Path(path)
    try:
        size = p.stat().st_size
        fh = p.open("rb")
    except OSError as exc:
        raise InputDataError(f"{p}: cannot open ({exc.strerror or exc})") from None
    scan = McapScan(path=str(p), size=size)
    emit = on_record or (lambda r: None)
    with fh:
        if size == 0:
            return scan
        buf: Any = mmap.mmap(fh.fileno(), 0, access=mmap.ACCESS_READ)
        try:
            _walk(buf, size, scan, emit, Header, Footer, Schema, Channel, Message, Chunk, DataEnd, breakup_chunk)
        finally:
            buf.close()
    return scan


def _walk(buf: Any, size: int, scan: McapScan, emit: Callable[[Any], None], Header: Any, Footer: Any,
          Schema: Any, Channel: Any, Message: Any, Chunk: Any, DataEnd: Any, breakup_chunk: Any) -> None:
    from mcap.stream_reader import CRCValidationError

    if size < 8 or bytes(buf[:8]) != MAGIC:
        if size < 8 and MAGIC.startswith(bytes(buf[:size])):
            scan.truncated_bytes, scan.truncated_at, scan.truncated_reason = size, 0, "cut inside the magic"
        return
    scan.magic = True
    pos = 8
    crc = zlib.crc32(MAGIC)
    crc_valid = True  # false once bytes were skipped: the running CRC no longer covers the file
    in_data = True
    scan.data_end = pos

    def resync(start: int, reason: str) -> int | None:
        nxt = start
        while True:
            nxt = buf.find(bytes([_OP_CHUNK]), nxt)
            if nxt < 0:
                return None
            if _chunk_header_ok(buf, nxt, size):
                try:
                    length = int.from_bytes(buf[nxt + 1:nxt + 9], "little")
                    ch = _read_record(Chunk, bytes(buf[nxt + 9:nxt + 9 + length]))
                    if ch.uncompressed_crc:
                        breakup_chunk(ch, validate_crc=True)
                        scan.damaged.append({"offset": start, "length": nxt - start, "reason": reason})
                        return int(nxt)
                except Exception:  # not a chunk after all
                    pass
            nxt += 1

    while pos < size:
        if size - pos < 9:
            scan.truncated_bytes, scan.truncated_at = size - pos, pos
            scan.truncated_reason = "cut inside a record header"
            break
        op = buf[pos]
        length = int.from_bytes(buf[pos + 1:pos + 9], "little")
        end = pos + 9 + length
        bad = _implausible(buf, pos, op, length, size, in_data, scan.chunks > 0)
        if bad:
            nxt = resync(pos + 1, bad)
            if nxt is None:
                scan.damaged.append({"offset": pos, "length": size - pos, "reason": f"{bad}, no intact chunk after it"})
                break
            pos, crc_valid = nxt, False
            continue
        if end > size:
            nxt = resync(pos + 1, f"record of opcode 0x{op:02x} claims {length} bytes past the end of the file")
            if nxt is None:
                scan.truncated_bytes, scan.truncated_at = size - pos, pos
                scan.truncated_reason = f"a record (opcode 0x{op:02x}) of {length} bytes is cut short"
                break
            pos, crc_valid = nxt, False
            continue
        body = bytes(buf[pos + 9:end])
        if op == _OP_DATA_END:
            try:
                rec = _read_record(DataEnd, body)
                if rec.data_section_crc and crc_valid:
                    scan.data_crc = "ok" if rec.data_section_crc == crc else "mismatch"
                elif rec.data_section_crc:
                    scan.data_crc = "mismatch"
            except Exception:
                pass
            scan.data_end, in_data = pos, False
        elif op == _OP_FOOTER:
            try:
                footer = _read_record(Footer, body)
                scan.complete = end + 8 <= size and bytes(buf[end:end + 8]) == MAGIC
                if footer.summary_crc:
                    # the CRC runs from the summary start through the footer's summary_offset_start field
                    first = int(footer.summary_start) or pos
                    ok = first <= pos and zlib.crc32(buf[first:pos + 25]) == footer.summary_crc
                    scan.summary_crc = "ok" if ok else "mismatch"
                    scan.summary_start = first
            except Exception:
                scan.damaged.append({"offset": pos, "length": 9 + length, "reason": "the footer does not decode"})
            pos = end
            break
        elif in_data:
            _data_record(op, body, length, pos, scan, emit, Header, Schema, Channel, Message, Chunk,
                         breakup_chunk, CRCValidationError)
        if in_data:
            crc = zlib.crc32(buf[pos:end], crc)
            scan.data_end = end
        pos = end


def _data_record(op: int, body: bytes, length: int, pos: int, scan: McapScan, emit: Callable[[Any], None],
                 Header: Any, Schema: Any, Channel: Any, Message: Any, Chunk: Any, breakup_chunk: Any,
                 CRCValidationError: Any) -> None:
    try:
        if op == _OP_HEADER:
            h = _read_record(Header, body)
            scan.header, scan.profile = True, str(h.profile)
        elif op == _OP_SCHEMA:
            emit(_read_record(Schema, body))
        elif op == _OP_CHANNEL:
            emit(_read_record(Channel, body))
        elif op == _OP_MESSAGE:
            emit(_read_record(Message, body, length))
            scan.messages += 1
        elif op == _OP_CHUNK:
            _chunk(body, length, pos, scan, emit, Chunk, Message, breakup_chunk, CRCValidationError)
    except Exception as exc:  # a top-level record that does not decode
        scan.damaged.append({"offset": pos, "length": 9 + length,
                             "reason": f"record opcode 0x{op:02x} does not decode ({type(exc).__name__})"})


def _chunk(body: bytes, length: int, pos: int, scan: McapScan, emit: Callable[[Any], None], Chunk: Any,
           Message: Any, breakup_chunk: Any, CRCValidationError: Any) -> None:
    scan.chunks += 1
    info: dict[str, Any] = {"offset": pos, "length": 9 + length}
    try:
        ch = _read_record(Chunk, body)
        info.update(start_ns=int(ch.message_start_time), end_ns=int(ch.message_end_time))
        if not ch.uncompressed_crc:
            scan.chunks_without_crc += 1
        records = breakup_chunk(ch, validate_crc=True)
    except CRCValidationError as exc:
        scan.skipped_chunks.append({**info, "reason": f"fails its CRC (stored {exc.expected:#010x}, "
                                                      f"computed {exc.actual:#010x})"})
        return
    except Exception as exc:
        scan.skipped_chunks.append({**info, "reason": f"does not decode ({type(exc).__name__}: "
                                                      f"{str(exc).splitlines()[0] if str(exc) else ''})"})
        return
    for r in records:
        if isinstance(r, Message):
            scan.messages += 1
        emit(r)


# --------------------------------------------------------------------------- bags


def mcap_files(bag: Path) -> list[Path]:
    """The MCAP files of a bag directory (or the file itself)."""
    if bag.is_file():
        return [bag]
    return sorted(bag.glob("*.mcap"))


def check_bag(path: str | os.PathLike[str]) -> list[McapScan]:
    """Walk every MCAP file of a bag and raise :class:`InputDataError` at the first defect.

    The message names the file and byte offset and suggests ``jointwear bag recover``.
    Bags in other storage (SQLite) are not checked here.
    """
    p = Path(path)
    bag = p.parent if p.is_file() else p
    scans = []
    for f in mcap_files(p):
        s = scan_mcap(f)
        scans.append(s)
        problems = s.problems
        if problems:
            offset, what = problems[0]
            more = f" (and {len(problems) - 1} more defect(s))" if len(problems) > 1 else ""
            if s.unfinished_only:
                raise InputDataError(
                    f"{f}: unfinished at byte {offset}: {what} (still being recorded, or the recorder was "
                    f"killed or ran out of disk); `jointwear bag recover {bag}` rebuilds a readable bag from it"
                )
            raise InputDataError(
                f"{f}: damaged at byte {offset}: {what}{more}; "
                f"`jointwear bag recover {bag}` rebuilds a readable bag from the intact chunks"
            )
    return scans


@dataclass
class RecoverReport:
    """What :func:`recover_bag` wrote and what it had to leave out."""

    bag: str
    source: str
    messages: int
    topics: dict[str, dict[str, Any]]
    skipped_chunks: list[dict[str, Any]]
    damaged: list[dict[str, Any]]
    truncated_bytes: int
    source_complete: bool
    data_crc: str
    #: messages whose channel definition was lost (it was in a skipped chunk): not written
    orphaned_messages: int
    #: where the topics' QoS and lost-message notes came from
    source_metadata: str
    start_ns: int = 0
    end_ns: int = 0

    def as_dict(self) -> dict[str, Any]:
        return {
            "bag": self.bag, "source": self.source, "messages": self.messages, "topics": self.topics,
            "skipped_chunks": self.skipped_chunks, "damaged": self.damaged,
            "truncated_bytes": self.truncated_bytes, "source_complete": self.source_complete,
            "data_crc": self.data_crc, "orphaned_messages": self.orphaned_messages,
            "source_metadata": self.source_metadata, "start_ns": self.start_ns, "end_ns": self.end_ns,
        }


def _old_metadata(bag: Path) -> tuple[dict[str, Any], str]:
    meta = bag / "metadata.yaml"
    if not meta.is_file():
        return {}, "missing"
    import yaml

    try:
        doc = yaml.safe_load(meta.read_text())
        info = doc.get("rosbag2_bagfile_information") if isinstance(doc, dict) else None
        if not isinstance(info, dict) or metadata_problem(info):
            return {}, "unreadable"  # rebuilt from the MCAP alone (a number where a list belongs, ...)
        return info, "read"
    except (yaml.YAMLError, OSError, UnicodeDecodeError):
        return {}, "unreadable"


def _iter_sources(src: Path) -> Iterator[Path]:
    files = mcap_files(src)
    if not files:
        raise InputDataError(f"{src}: no .mcap file to recover (give the bag directory or its .mcap file)")
    yield from files


def _looks_like_mcap(f: Path) -> bool:
    """The file starts with the MCAP magic, or with as much of it as it holds (a recording cut at its first bytes,
    or never written: a zero-byte file of a killed recorder is an empty bag)."""
    try:
        with f.open("rb") as fh:
            head = fh.read(len(MAGIC))
    except OSError as exc:
        raise InputDataError(f"{f}: cannot open ({exc.strerror or exc})") from None
    return MAGIC.startswith(head) if len(head) < len(MAGIC) else head == MAGIC


def _refuse_non_bag(src: Path, sources: list[Path]) -> None:
    """A source none of whose files is MCAP (a text file, a directory of files named .mcap that are not) is not
    a bag: nothing could be recovered from it, and nothing is written."""
    if src.is_file() and src.suffix != ".mcap" and not (src.stat().st_size and _looks_like_mcap(src)):
        raise InputDataError(f"{src}: not a bag (recover reads a rosbag2 MCAP bag: its directory or its .mcap "
                             "file); nothing written")
    if not any(_looks_like_mcap(f) for f in sources):
        which = (f"{sources[0].name} does not start" if len(sources) == 1 else
                 f"none of its {len(sources)} .mcap files starts")
        raise InputDataError(f"{src}: not an MCAP bag ({which} with the MCAP magic); nothing written")


def recover_bag(src: str | os.PathLike[str], out: str | os.PathLike[str] | None = None) -> RecoverReport:
    """Rebuild a readable rosbag2 bag from ``src`` (a bag directory or .mcap file) into ``out``.

    ``out`` defaults to ``<src>_recovered`` beside the source bag; it must not
    exist. Writes into a temporary directory renamed to ``out`` at the end, so
    a failure leaves nothing half-written. ``src`` is only read.
    """
    from .mcap_bag import OPEN_KEY, McapBagWriter

    s = Path(src)
    if not s.exists():
        raise InputDataError(f"{s}: no such bag or file")
    sources = list(_iter_sources(s))
    _refuse_non_bag(s, sources)  # before --out is chosen or checked: a non-bag writes nothing anywhere
    bag_dir = (s.parent if s.is_file() else s).resolve()  # absolute: "x.mcap" run from its own folder has parent "."
    dst = Path(out) if out is not None else bag_dir.with_name(bag_dir.name + "_recovered")
    if dst.exists():
        raise InputDataError(f"{dst}: already exists; give a new --out directory (recover never overwrites)")
    if not dst.parent.is_dir():
        raise InputDataError(f"{dst.parent}: no such directory for --out")
    if dst.resolve() == bag_dir.resolve() or bag_dir.resolve() in dst.resolve().parents:
        raise InputDataError(f"{dst}: --out must be outside the source bag {bag_dir}")
    old, old_state = _old_metadata(bag_dir)
    old_qos: dict[str, list[Any]] = {}
    for t in old.get("topics_with_message_count") or []:
        try:
            tm = t["topic_metadata"]
            if isinstance(tm.get("offered_qos_profiles"), list):
                old_qos[str(tm["name"])] = tm["offered_qos_profiles"]
        except (KeyError, TypeError, AttributeError):
            continue
    custom = old.get("custom_data") if isinstance(old.get("custom_data"), dict) else {}
    custom = {str(k): str(v) for k, v in (custom or {}).items() if k not in (OPEN_KEY, RECOVERED_KEY)}

    tmp = dst.parent / f".{dst.name}.partial-{os.getpid()}"
    try:
        if tmp.exists():
            shutil.rmtree(tmp)
        writer = McapBagWriter(tmp, name=dst.name, fsync=False, custom_data=custom)
    except OSError as exc:
        raise InputDataError(f"{dst}: cannot write the recovered bag there ({exc.strerror or exc})") from None
    try:
        report = _copy(sources, writer, old_qos)
        report_custom = {
            "source": str(s), "skipped_chunks": len(report["skipped"]), "damaged_regions": len(report["damaged"]),
            "truncated_bytes": report["truncated"], "orphaned_messages": report["orphaned"],
        }
        writer.custom_data[RECOVERED_KEY] = json.dumps(report_custom, sort_keys=True)
        writer.close()
        os.replace(tmp, dst)
    except BaseException as exc:
        writer.abort()
        shutil.rmtree(tmp, ignore_errors=True)
        if isinstance(exc, OSError):
            raise InputDataError(f"{dst}: writing the recovered bag failed ({exc.strerror or exc}); "
                                 "nothing was left there") from None
        raise
    topics = {t.name: {"type": t.msgtype, "count": t.count} for t in writer.topics()}
    return RecoverReport(
        bag=str(dst), source=str(s), messages=writer.count, topics=dict(sorted(topics.items())),
        skipped_chunks=report["skipped"], damaged=report["damaged"], truncated_bytes=report["truncated"],
        source_complete=report["complete"], data_crc=report["data_crc"], orphaned_messages=report["orphaned"],
        source_metadata=old_state, start_ns=report["start"], end_ns=report["end"],
    )


def _copy(sources: list[Path], writer: Any, old_qos: dict[str, list[Any]]) -> dict[str, Any]:
    from mcap.records import Channel, Message, Schema

    skipped: list[dict[str, Any]] = []
    damaged: list[dict[str, Any]] = []
    truncated = orphaned = 0
    complete = True
    crcs: list[str] = []
    times: list[int] = []
    for f in sources:
        schemas: dict[int, Any] = {}
        channels: dict[int, int] = {}  # source channel id -> our channel id
        by_topic: dict[tuple[str, str], int] = {}

        def on_record(r: Any, schemas: dict[int, Any] = schemas, channels: dict[int, int] = channels,
                      by_topic: dict[tuple[str, str], int] = by_topic) -> None:
            nonlocal orphaned
            if isinstance(r, Schema):
                schemas[r.id] = r
            elif isinstance(r, Channel):
                if r.id in channels:
                    return
                sch = schemas.get(r.schema_id)
                if sch is None:
                    return  # its schema was lost: its messages will count as orphaned
                key = (r.topic, sch.name)
                if key not in by_topic:
                    qos = _channel_qos(r.metadata.get("offered_qos_profiles", ""), old_qos.get(r.topic))
                    by_topic[key] = writer.add_connection(
                        r.topic, sch.name, sch.data.decode("utf-8", "replace"), encoding=sch.encoding or "ros2msg",
                        rihs01=r.metadata.get("topic_type_hash", ""), offered_qos_profiles=qos,
                        serialization_format=r.message_encoding or "cdr")
                channels[r.id] = by_topic[key]
            elif isinstance(r, Message):
                cid = channels.get(r.channel_id)
                if cid is None:
                    orphaned += 1
                    return
                writer.write(cid, r.log_time, r.data)
                if times:
                    times[0], times[1] = min(times[0], r.log_time), max(times[1], r.log_time)
                else:
                    times.extend([r.log_time, r.log_time])

        scan = scan_mcap(f, on_record)
        skipped += [{"file": f.name, **c} for c in scan.skipped_chunks]
        damaged += [{"file": f.name, **d} for d in scan.damaged]
        truncated += scan.truncated_bytes
        complete = complete and scan.complete
        crcs.append(scan.data_crc)
        if scan.size and not scan.magic and not scan.truncated_bytes:
            damaged.append({"file": f.name, "offset": 0, "length": scan.size, "reason": "not an MCAP file"})
    data_crc = "mismatch" if "mismatch" in crcs else ("ok" if crcs and all(c == "ok" for c in crcs) else "absent")
    return {"skipped": skipped, "damaged": damaged, "truncated": truncated, "orphaned": orphaned,
            "complete": complete, "data_crc": data_crc, "start": times[0] if times else 0,
            "end": times[1] if times else 0}


def _channel_qos(text: str, fallback: list[Any] | None) -> list[dict[str, Any]]:
    import yaml

    if text:
        try:
            value = yaml.safe_load(text)
            if isinstance(value, list) and all(isinstance(v, dict) for v in value):
                return value
        except yaml.YAMLError:
            pass
    return [v for v in (fallback or []) if isinstance(v, dict)]
