!> Checks a model's analytic Jacobians against central differences: the
!> test every built-in model passes and a user's own model should.
module mlid_jacobian_check
  use mlid_kinds, only: wp
  use mlid_models, only: model_t
  implicit none
  private
  public :: check_jacobians

contains

  !> err = largest relative error of (df/dx, df/dp, dh/dx, dh/dp, df/dw,
  !> dh/dw) at (t, x, u, p), each column scaled by max(1, its largest entry).
  !> u = [controls; process noise]: the noise-dependent terms are checked too.
  !> dh/dw against the change of h + (dh/dw) w that the noise makes in f's
  !> output rows is not defined generally, so it is checked as linear: the
  !> difference of (dh/dw) at two noise values must vanish.
  !> The Jacobians checked are those of one evaluation asked for everything
  !> (model_t%eval, as the output-error integration asks where a step starts
  !> at a sample); asked for the stages' part (f and its Jacobians), the
  !> outputs' part, or one quantity alone, it must give the same numbers,
  !> and any difference counts in err(1:4) too.
  subroutine check_jacobians(m, t, x, u, p, err)
    class(model_t), intent(in) :: m
    real(wp), intent(in) :: t, x(:), u(:), p(:)
    real(wp), intent(out) :: err(6)
    real(wp) :: a(m%nx, m%nx), b(m%nx, m%np), c(m%ny, m%nx), d(m%ny, m%np)
    real(wp) :: g(m%nx, m%nw), dw(m%ny, m%nw), dw2(m%ny, m%nw), u2(size(u))
    real(wp) :: fp(m%nx), fm(m%nx), yp(m%ny), ym(m%ny), ex(m%nx), ep(m%np), h
    real(wp) :: eu(size(u)), f0(m%nx), y0(m%ny), f1(m%nx), y1(m%ny)
    real(wp) :: a1(m%nx, m%nx), b1(m%nx, m%np), c1(m%ny, m%nx), d1(m%ny, m%np)
    integer :: k, idx(m%np)

    idx = [(k, k=1, m%np)]
    call m%eval(t, x, u, p, idx, xdot=f0, a=a, b=b, y=y0, c=c, d=d)
    err = 0.0_wp
    call m%eval(t, x, u, p, idx, xdot=f1, a=a1, b=b1)          ! a stage's part
    call m%eval(t, x, u, p, idx, y=y1, c=c1, d=d1)             ! an output's part
    err(1) = max(rel(f1, f0), rel(flat(a1), flat(a)))
    err(2) = rel(flat(b1), flat(b))
    err(3) = max(rel(y1, y0), rel(flat(c1), flat(c)))
    err(4) = rel(flat(d1), flat(d))
    call m%f(t, x, u, p, f1)                                   ! one quantity at a time
    call m%dfdx(t, x, u, p, a1)
    call m%dfdp(t, x, u, p, idx, b1)
    call m%h(t, x, u, p, y1)
    call m%dhdx(t, x, u, p, c1)
    call m%dhdp(t, x, u, p, idx, d1)
    err(1) = max(err(1), rel(f1, f0), rel(flat(a1), flat(a)))
    err(2) = max(err(2), rel(flat(b1), flat(b)))
    err(3) = max(err(3), rel(y1, y0), rel(flat(c1), flat(c)))
    err(4) = max(err(4), rel(flat(d1), flat(d)))
    do k = 1, m%nx
      h = 1.0e-6_wp*max(1.0_wp, abs(x(k)))
      ex = 0.0_wp
      ex(k) = h
      call m%f(t, x + ex, u, p, fp)
      call m%f(t, x - ex, u, p, fm)
      call m%h(t, x + ex, u, p, yp)
      call m%h(t, x - ex, u, p, ym)
      err(1) = max(err(1), rel((fp - fm)/(2*h), a(:, k)))
      err(3) = max(err(3), rel((yp - ym)/(2*h), c(:, k)))
    end do
    do k = 1, m%np
      h = 1.0e-6_wp*max(1.0_wp, abs(p(k)))
      ep = 0.0_wp
      ep(k) = h
      call m%f(t, x, u, p + ep, fp)
      call m%f(t, x, u, p - ep, fm)
      call m%h(t, x, u, p + ep, yp)
      call m%h(t, x, u, p - ep, ym)
      err(2) = max(err(2), rel((fp - fm)/(2*h), b(:, k)))
      err(4) = max(err(4), rel((yp - ym)/(2*h), d(:, k)))
    end do
    call m%dfdw(t, x, u, p, g)
    do k = 1, m%nw
      if (m%nu + k > size(u)) exit
      h = 1.0e-6_wp*max(1.0_wp, abs(u(m%nu + k)))
      eu = 0.0_wp
      eu(m%nu + k) = h
      call m%f(t, x, u + eu, p, fp)
      call m%f(t, x, u - eu, p, fm)
      err(5) = max(err(5), rel((fp - fm)/(2*h), g(:, k)))
    end do
    ! the noise in the outputs is (dh/dw) w: dh/dw must not depend on w
    call m%dhdw(t, x, u, p, dw)
    u2 = u
    if (size(u) > m%nu) u2(m%nu + 1:) = 0.0_wp
    call m%dhdw(t, x, u2, p, dw2)
    do k = 1, m%nw
      err(6) = max(err(6), rel(dw2(:, k), dw(:, k)))
    end do

  contains

    pure real(wp) function rel(fd, an)
      real(wp), intent(in) :: fd(:), an(:)
      rel = maxval(abs(fd - an))/max(1.0_wp, maxval(abs(an)))
      if (any(fd /= fd) .or. any(an /= an)) rel = huge(1.0_wp)   ! a NaN is never right
    end function rel

    pure function flat(mat) result(v)
      real(wp), intent(in) :: mat(:, :)
      real(wp) :: v(size(mat))
      v = reshape(mat, [size(mat)])
    end function flat

  end subroutine check_jacobians

end module mlid_jacobian_check
