use core::ops::{Add, Mul, Neg, Sub};

/// A point or vector in the plane, millimetres.
///
/// ```
/// use hollowpath::geometry::Point;
/// let p = Point::new(3.0, 4.0);
/// assert_eq!(p.norm(), 5.0);
/// assert_eq!((p - Point::new(1.0, 1.0)).x, 2.0);
/// ```
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Point {
    /// x, mm.
    pub x: f32,
    /// y, mm.
    pub y: f32,
}

impl Point {
    /// A point from its coordinates.
    pub const fn new(x: f32, y: f32) -> Self {
        Point { x, y }
    }
    /// Dot product.
    pub fn dot(self, o: Point) -> f32 {
        self.x * o.x + self.y * o.y
    }
    /// z of the cross product.
    pub fn cross(self, o: Point) -> f32 {
        self.x * o.y - self.y * o.x
    }
    /// Squared length.
    pub fn norm2(self) -> f32 {
        self.dot(self)
    }
    /// Length (`hollowpath_fpu::sqrtf`).
    pub fn norm(self) -> f32 {
        hollowpath_fpu::sqrtf(self.norm2())
    }
    /// Distance to another point.
    pub fn dist(self, o: Point) -> f32 {
        (self - o).norm()
    }
    /// The unit vector along `self`, or zero for (almost) zero vectors.
    pub fn normalized(self) -> Point {
        let n = self.norm();
        if n > 1e-12 {
            self * (1.0 / n)
        } else {
            Point::default()
        }
    }
    /// Rotated a quarter turn counter-clockwise.
    pub fn perp(self) -> Point {
        Point::new(-self.y, self.x)
    }
    /// `self + (o - self) * t`.
    pub fn lerp(self, o: Point, t: f32) -> Point {
        self + (o - self) * t
    }
    /// Both coordinates finite.
    pub fn is_finite(self) -> bool {
        self.x.is_finite() && self.y.is_finite()
    }
}

impl Add for Point {
    type Output = Point;
    fn add(self, o: Point) -> Point {
        Point::new(self.x + o.x, self.y + o.y)
    }
}
impl Sub for Point {
    type Output = Point;
    fn sub(self, o: Point) -> Point {
        Point::new(self.x - o.x, self.y - o.y)
    }
}
impl Mul<f32> for Point {
    type Output = Point;
    fn mul(self, k: f32) -> Point {
        Point::new(self.x * k, self.y * k)
    }
}
impl Neg for Point {
    type Output = Point;
    fn neg(self) -> Point {
        Point::new(-self.x, -self.y)
    }
}
