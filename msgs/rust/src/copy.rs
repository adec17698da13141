//! Copying a message into another one that already has its buffers.
//!
//! `#[derive(Clone)]` gives `clone` only, and the default `clone_from` is
//! `*self = source.clone()`, which allocates every `String` and `Vec` again. A real-time
//! loop that hands its messages to a publisher thread (ros2_control's
//! `realtime_tools::RealtimePublisher` does the same) needs the copy to reuse the
//! destination's capacity instead: [`CopyFrom::copy_from`] allocates only where the
//! destination is shorter than the source.

/// Field-wise copy that reuses the destination's `String` and `Vec` buffers.
pub trait CopyFrom {
    fn copy_from(&mut self, src: &Self);
}

macro_rules! copy_plain {
    ($($t:ty),*) => {$(
        impl CopyFrom for $t {
            fn copy_from(&mut self, src: &Self) {
                *self = *src;
            }
        }
    )*};
}

copy_plain!(bool, u8, i8, u16, i16, u32, i32, u64, i64, f32, f64);

impl CopyFrom for String {
    fn copy_from(&mut self, src: &Self) {
        // String::clone_from reuses the buffer when it is large enough.
        self.clone_from(src);
    }
}

impl<T: CopyFrom + Default> CopyFrom for Vec<T> {
    fn copy_from(&mut self, src: &Self) {
        self.truncate(src.len());
        for (d, s) in self.iter_mut().zip(src) {
            d.copy_from(s);
        }
        for s in &src[self.len()..] {
            let mut d = T::default();
            d.copy_from(s);
            self.push(d);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Float64MultiArray, JointState, MultiArrayDimension, Time};

    #[test]
    fn copy_from_equals_clone_and_reuses_the_buffers() {
        let a = JointState {
            name: vec!["joint1".into(), "joint2".into()],
            position: vec![0.5, -1.0],
            velocity: vec![0.1, 0.2],
            effort: vec![3.0, 4.0],
            ..Default::default()
        };
        let mut b = JointState { name: vec!["a-longer-name".into(), "another-long-one".into(), "x".into()], position: vec![0.0; 4], ..Default::default() };
        let (names, pos) = (b.name[0].as_ptr(), b.position.as_ptr());
        b.copy_from(&a);
        assert_eq!(b, a);
        assert_eq!((b.name[0].as_ptr(), b.position.as_ptr()), (names, pos), "buffers reused");
        // A shorter destination grows to the source.
        let mut c = JointState::default();
        c.copy_from(&a);
        assert_eq!(c, a);
        let mut m = Float64MultiArray::default();
        let src = Float64MultiArray { data: vec![1.0, 2.0], ..Default::default() };
        let mut src2 = src.clone();
        src2.layout.dim.push(MultiArrayDimension { label: "stamp_ns=5".into(), size: 2, stride: 2 });
        m.copy_from(&src2);
        assert_eq!(m, src2);
        m.copy_from(&src);
        assert_eq!(m, src);
        let mut t = Time::default();
        t.copy_from(&Time::from_nanos(1_500_000_001));
        assert_eq!(t.to_nanos(), 1_500_000_001);
    }
}
