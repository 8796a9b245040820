-- imubench lab database, migration 2: raw samples ([lab] mirror_samples = true in a bench file).
-- Applied once, in one transaction, by tools/lab-db.sh (psql -1 -f).
--
-- One table per stream, as in each bench's SQLite store (daemon/store.cpp), keyed by
-- (bench_id, run_id, t): a stream's rows of a run have strictly increasing times, so t is the
-- row's sequence. Values are float8, bit-exact copies of the store's doubles; NULL where the
-- store holds NULL (an IMU temperature not reported, a table reading's unknown round trip).
--
-- lab.sample_marks is how far each (bench, run, stream) has been shipped: the shipper
-- (lab/sample_shipper.h) updates it in the same transaction as the rows it copies, so the rows
-- and the mark commit together or not at all; a shipper that dies at any point resumes after
-- the committed mark. The rows are inserted with ON CONFLICT DO NOTHING as well: a mark lost
-- or reset (e.g. deleted by hand) re-ships rows without duplicating them.
CREATE TABLE lab.imu_samples(
  bench_id text NOT NULL DEFAULT current_user,
  run_id bigint NOT NULL,
  t float8 NOT NULL,
  dthx float8 NOT NULL, dthy float8 NOT NULL, dthz float8 NOT NULL,
  dvx float8 NOT NULL, dvy float8 NOT NULL, dvz float8 NOT NULL,
  temp_c float8,
  PRIMARY KEY (bench_id, run_id, t)
);
CREATE TABLE lab.table_samples(
  bench_id text NOT NULL DEFAULT current_user,
  run_id bigint NOT NULL,
  t float8 NOT NULL,
  angle0_deg float8 NOT NULL, angle1_deg float8 NOT NULL, angle2_deg float8 NOT NULL,
  round_trip_s float8,
  PRIMARY KEY (bench_id, run_id, t)
);
CREATE TABLE lab.chamber_samples(
  bench_id text NOT NULL DEFAULT current_user,
  run_id bigint NOT NULL,
  t float8 NOT NULL,
  setpoint_c float8 NOT NULL,
  temp_c float8 NOT NULL,
  PRIMARY KEY (bench_id, run_id, t)
);
CREATE TABLE lab.sample_marks(
  bench_id text NOT NULL DEFAULT current_user,
  run_id bigint NOT NULL,
  stream text NOT NULL CHECK (stream IN ('imu', 'table', 'chamber')),
  shipped_t float8 NOT NULL,  -- every row of the stream with t <= shipped_t is in the lab
  shipped_rows bigint NOT NULL,
  updated_at timestamptz NOT NULL DEFAULT now(),
  PRIMARY KEY (bench_id, run_id, stream)
);

-- Row security as for lab.items: a bench's writer writes only its own rows.
ALTER TABLE lab.imu_samples ENABLE ROW LEVEL SECURITY;
ALTER TABLE lab.table_samples ENABLE ROW LEVEL SECURITY;
ALTER TABLE lab.chamber_samples ENABLE ROW LEVEL SECURITY;
ALTER TABLE lab.sample_marks ENABLE ROW LEVEL SECURITY;
CREATE POLICY writer_own_bench ON lab.imu_samples TO lab_writer
  USING (bench_id = current_user) WITH CHECK (bench_id = current_user);
CREATE POLICY writer_own_bench ON lab.table_samples TO lab_writer
  USING (bench_id = current_user) WITH CHECK (bench_id = current_user);
CREATE POLICY writer_own_bench ON lab.chamber_samples TO lab_writer
  USING (bench_id = current_user) WITH CHECK (bench_id = current_user);
CREATE POLICY writer_own_bench ON lab.sample_marks TO lab_writer
  USING (bench_id = current_user) WITH CHECK (bench_id = current_user);
CREATE POLICY reader_all ON lab.imu_samples FOR SELECT TO lab_reader USING (true);
CREATE POLICY reader_all ON lab.table_samples FOR SELECT TO lab_reader USING (true);
CREATE POLICY reader_all ON lab.chamber_samples FOR SELECT TO lab_reader USING (true);
CREATE POLICY reader_all ON lab.sample_marks FOR SELECT TO lab_reader USING (true);

-- The readers' views: one per stream, with the run's IMU serial and plan (lab.runs).
CREATE VIEW lab.imu AS
  SELECT s.bench_id, s.run_id, r.imu_serial, r.plan_name, s.t, s.dthx, s.dthy, s.dthz,
         s.dvx, s.dvy, s.dvz, s.temp_c
  FROM lab.imu_samples s LEFT JOIN lab.runs r USING (bench_id, run_id);
CREATE VIEW lab.table_angles AS
  SELECT s.bench_id, s.run_id, r.imu_serial, r.plan_name, s.t, s.angle0_deg, s.angle1_deg,
         s.angle2_deg, s.round_trip_s
  FROM lab.table_samples s LEFT JOIN lab.runs r USING (bench_id, run_id);
CREATE VIEW lab.chamber AS
  SELECT s.bench_id, s.run_id, r.imu_serial, r.plan_name, s.t, s.setpoint_c, s.temp_c
  FROM lab.chamber_samples s LEFT JOIN lab.runs r USING (bench_id, run_id);

GRANT SELECT, INSERT, UPDATE ON lab.imu_samples, lab.table_samples, lab.chamber_samples,
  lab.sample_marks TO lab_writer;
GRANT SELECT ON lab.imu_samples, lab.table_samples, lab.chamber_samples, lab.sample_marks,
  lab.imu, lab.table_angles, lab.chamber TO lab_reader;

INSERT INTO lab.schema_version(version) VALUES (2);
