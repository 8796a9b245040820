-- imubench lab database, migration 1: the mirrored items, their roles and the readers' views.
-- Applied once, in one transaction, by tools/lab-db.sh (psql -1 -f); lab.schema_version says
-- which migrations a database has. The daemon's shipper (lab/shipper.h) refuses to write into
-- a database whose newest version differs from its own (LabSchemaVersion()).
--
-- Every mirrored item is one row keyed by (bench_id, run_id, item): a bench's run 'run', its
-- 'event/N', 'result/N', 'segment/N' and the queue's 'queue/N' (run_id 0). The payload is the
-- JSON the bench's SQLite outbox wrote (daemon/store.cpp lab_item_* views). bench_id is the
-- writing role (current_user): a bench's writer can only write its own rows (row security).
DO $$ BEGIN
  IF NOT EXISTS (SELECT FROM pg_roles WHERE rolname = 'lab_writer') THEN
    CREATE ROLE lab_writer NOLOGIN;
  END IF;
  IF NOT EXISTS (SELECT FROM pg_roles WHERE rolname = 'lab_reader') THEN
    CREATE ROLE lab_reader NOLOGIN;
  END IF;
END $$;

CREATE SCHEMA lab;
CREATE TABLE lab.schema_version(
  version integer PRIMARY KEY,
  applied_at timestamptz NOT NULL DEFAULT now()
);
CREATE TABLE lab.items(
  bench_id text NOT NULL DEFAULT current_user,
  run_id bigint NOT NULL,
  item text NOT NULL,
  kind text NOT NULL,
  payload jsonb NOT NULL,
  outbox_seq bigint NOT NULL,
  shipped_at timestamptz NOT NULL DEFAULT now(),
  PRIMARY KEY (bench_id, run_id, item)
);
CREATE INDEX items_by_serial ON lab.items ((payload->>'imu_serial')) WHERE kind IN ('run', 'result');

ALTER TABLE lab.items ENABLE ROW LEVEL SECURITY;
CREATE POLICY writer_own_bench ON lab.items TO lab_writer
  USING (bench_id = current_user) WITH CHECK (bench_id = current_user);
CREATE POLICY reader_all ON lab.items FOR SELECT TO lab_reader USING (true);

CREATE VIEW lab.runs AS
  SELECT bench_id, run_id, payload->>'plan_name' AS plan_name,
         payload->>'bench_name' AS bench_name, payload->>'imu_serial' AS imu_serial,
         payload->>'state' AS state, (payload->>'started_unix_s')::float8 AS started_unix_s,
         (payload->>'finished_unix_s')::float8 AS finished_unix_s,
         payload->>'exit_reason' AS exit_reason, payload
  FROM lab.items WHERE kind = 'run';
CREATE VIEW lab.results AS
  SELECT bench_id, run_id, (payload->>'id')::bigint AS result_id,
         payload->>'imu_serial' AS imu_serial, (payload->>'temperature_c')::float8 AS temperature_c,
         payload->>'kind' AS kind, payload->'result' AS result,
         (payload->>'created_unix_s')::float8 AS created_unix_s
  FROM lab.items WHERE kind = 'result';
CREATE VIEW lab.events AS
  SELECT bench_id, run_id, (payload->>'id')::bigint AS event_id,
         (payload->>'wall_unix_s')::float8 AS wall_unix_s, payload->>'severity' AS severity,
         payload->>'kind' AS kind, payload->'details' AS details
  FROM lab.items WHERE kind = 'event';

GRANT USAGE ON SCHEMA lab TO lab_writer, lab_reader;
GRANT SELECT ON lab.schema_version TO lab_writer, lab_reader;
GRANT SELECT, INSERT, UPDATE, DELETE ON lab.items TO lab_writer;
GRANT SELECT ON lab.items, lab.runs, lab.results, lab.events TO lab_reader;

INSERT INTO lab.schema_version(version) VALUES (1);
