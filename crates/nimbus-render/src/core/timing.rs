//! Per-pass GPU timing with timestamp queries: each pass writes a timestamp
//! at its beginning and end; after the frame is submitted the pairs are read
//! back and converted to milliseconds with the queue's timestamp period.

/// Timestamp queries for a fixed list of passes.
#[derive(Debug)]
pub struct GpuTimer {
    query_set: wgpu::QuerySet,
    resolve: wgpu::Buffer,
    readback: wgpu::Buffer,
    pass_count: u32,
    period_ns: f64,
}

impl GpuTimer {
    /// A timer for `pass_count` passes, or `None` when the device lacks timestamp queries.
    pub fn new(device: &wgpu::Device, queue: &wgpu::Queue, pass_count: u32) -> Option<Self> {
        if !device.features().contains(wgpu::Features::TIMESTAMP_QUERY) {
            return None;
        }
        let count = pass_count * 2;
        let query_set = device.create_query_set(&wgpu::QuerySetDescriptor {
            label: Some("pass timestamps"),
            ty: wgpu::QueryType::Timestamp,
            count,
        });
        let size = count as u64 * wgpu::QUERY_SIZE as u64;
        let resolve = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("timestamp resolve"),
            size,
            usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let readback = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("timestamp readback"),
            size,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        Some(Self {
            query_set,
            resolve,
            readback,
            pass_count,
            period_ns: queue.get_timestamp_period() as f64,
        })
    }

    /// The query set (for passes split over several render passes).
    pub fn query_set(&self) -> &wgpu::QuerySet {
        &self.query_set
    }

    /// The timestamp writes of pass `index` (in the renderer's pass order).
    pub fn pass_writes(&self, index: u32) -> wgpu::RenderPassTimestampWrites<'_> {
        wgpu::RenderPassTimestampWrites {
            query_set: &self.query_set,
            beginning_of_pass_write_index: Some(index * 2),
            end_of_pass_write_index: Some(index * 2 + 1),
        }
    }

    /// The timestamp writes of compute pass `index`.
    pub fn compute_pass_writes(&self, index: u32) -> wgpu::ComputePassTimestampWrites<'_> {
        wgpu::ComputePassTimestampWrites {
            query_set: &self.query_set,
            beginning_of_pass_write_index: Some(index * 2),
            end_of_pass_write_index: Some(index * 2 + 1),
        }
    }

    /// Records the resolve and the copy to the readback buffer (end of frame).
    pub fn resolve(&self, encoder: &mut wgpu::CommandEncoder) {
        encoder.resolve_query_set(&self.query_set, 0..self.pass_count * 2, &self.resolve, 0);
        encoder.copy_buffer_to_buffer(&self.resolve, 0, &self.readback, 0, self.resolve.size());
    }

    /// Waits for the frame and returns each pass's GPU time in milliseconds
    /// (an error message if the read-back failed, e.g. on device loss).
    pub fn read_ms(&self, device: &wgpu::Device) -> Result<Vec<f64>, String> {
        let bytes = crate::core::binding::read_mapped(device, &self.readback)?;
        let times: Vec<u64> = bytemuck::pod_collect_to_vec(&bytes);
        Ok(times
            .chunks(2)
            .map(|pair| pair[1].saturating_sub(pair[0]) as f64 * self.period_ns * 1e-6)
            .collect())
    }
}
